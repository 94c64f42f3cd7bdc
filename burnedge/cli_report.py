"""The report and export commands of the CLI: an encounter's clinical report (PDF), the encounter as a FHIR R4
Bundle written to a file, or as a DICOM study written to a folder or sent to a PACS."""

from __future__ import annotations

import argparse
import getpass
import json
from collections.abc import Callable
from pathlib import Path

from burnedge.cli_help import examples
from schemas.config import Config
from schemas.errors import InvalidInput, NotFound


def _check_target(config: Config, out: Path, example: str) -> None:
    if not Path(config.gateway.database).exists():
        raise NotFound(f"no database at {config.gateway.database}")
    if out.is_dir():
        raise InvalidInput(f"{out} is a folder: give the file to write, e.g. {out / example}")
    if not out.parent.is_dir():
        raise InvalidInput(f"the folder {out.parent} does not exist")


def _on_the_gateway(config: Config, out: Path, example: str, act):
    """act(services) with the gateway's services over its database, after checking `out` can be written."""
    from gateway.dependencies import Services
    from gateway.storage.database import Database

    _check_target(config, out, example)
    db = Database.from_config(config.gateway)
    try:
        return act(Services.build(config, db))
    finally:
        db.close()


def write_report(config: Config, encounter_id: str, out: Path, made_by: str) -> dict:
    """Make (or reuse) the report and write it to `out`; what was done, as the command prints it."""
    from base.storage.durable import replace_atomically

    made = _on_the_gateway(config, out, "report.pdf", lambda s: s.reports.make(None, encounter_id, made_by=made_by))
    replace_atomically(out, made.pdf)
    return {"encounter_id": encounter_id, "out": str(out), "bytes": len(made.pdf), "made": made.made}


def write_fhir(config: Config, encounter_id: str, out: Path, made_by: str) -> dict:
    """Export the encounter as a FHIR R4 Bundle (JSON) to `out`; what was done, as the command prints it."""
    from base.storage.durable import replace_atomically

    bundle = _on_the_gateway(
        config, out, "encounter.fhir.json", lambda s: s.fhir.export(None, encounter_id, made_by=made_by)
    )
    data = json.dumps(bundle, ensure_ascii=False, indent=1).encode()
    replace_atomically(out, data)
    return {"encounter_id": encounter_id, "out": str(out), "bytes": len(data), "resources": len(bundle["entry"])}


def export_dicom(config: Config, encounter_id: str, out: Path | None, to: str, made_by: str) -> dict:
    """Write the encounter's DICOM study to the folder `out`, send it to the PACS (`to`, or [dicom] endpoint when
    `to` is "config"), or both; what was done, as the command prints it."""
    from gateway.dependencies import Services
    from gateway.storage.database import Database

    if not Path(config.gateway.database).exists():
        raise NotFound(f"no database at {config.gateway.database}")
    if out is None and not to:
        raise InvalidInput("say where the study goes: --out FOLDER, --to URL (a DICOMweb root), or both")
    if out is not None and out.exists() and not out.is_dir():
        raise InvalidInput(f"{out} is a file: give the folder to write the study's files in")
    db = Database.from_config(config.gateway)
    try:
        services = Services.build(config, db)
        done: dict = {"encounter_id": encounter_id}
        if out is not None:
            written = services.dicom.write(None, encounter_id, out, made_by=made_by)
            done |= {"out": str(out), "files": [p.name for p in written]}
        if to:
            sent = services.dicom.send(None, encounter_id, "" if to == "config" else to, made_by=made_by)
            done |= {
                "sent_to": sent.endpoint,
                "study_uid": sent.study_uid,
                "objects": sent.instances,
                "already_there": sent.already_there,
            }
        return done
    finally:
        db.close()


def cmd_export_dicom(args: argparse.Namespace, config: Config) -> int:
    by = f"{getpass.getuser()} (burnedge export dicom on the gateway)"
    out = Path(args.out) if args.out else None
    print(json.dumps(export_dicom(config, args.encounter_id, out, args.to or "", by)))
    return 0


def cmd_report(args: argparse.Namespace, config: Config) -> int:
    by = f"{getpass.getuser()} (burnedge report on the gateway)"
    print(json.dumps(write_report(config, args.encounter_id, Path(args.out), by)))
    return 0


def cmd_export_fhir(args: argparse.Namespace, config: Config) -> int:
    by = f"{getpass.getuser()} (burnedge export fhir on the gateway)"
    print(json.dumps(write_fhir(config, args.encounter_id, Path(args.out), by)))
    return 0


def add_commands(sub, load: Callable[[argparse.Namespace], Config]) -> None:
    report = sub.add_parser(
        "report",
        help="write an encounter's clinical report (PDF)",
        **examples(
            "burnedge report 0192f3b4-6a8f-7000-8000-00000000f000 --out report.pdf",
            "burnedge --db burnedge-demo.sqlite3 report 0192f3b4-6a8f-7000-8000-00000000f000 --out day0.pdf",
        ),
    )
    report.add_argument("encounter_id", help="the encounter's id")
    report.add_argument("--out", required=True, help="the PDF file to write")
    report.set_defaults(func=lambda args: cmd_report(args, load(args)))
    export = sub.add_parser(
        "export",
        help="export an encounter in a standard format",
        **examples("burnedge export fhir 0192f3b4-6a8f-7000-8000-00000000f000 --out encounter.fhir.json"),
    ).add_subparsers(dest="format", required=True, metavar="FORMAT")
    fhir = export.add_parser(
        "fhir",
        help="the encounter as one FHIR R4 Bundle (JSON); codes and units in docs/fhir.md",
        **examples(
            "burnedge export fhir 0192f3b4-6a8f-7000-8000-00000000f000 --out encounter.fhir.json",
            "burnedge --db burnedge-demo.sqlite3 export fhir 0192f3b4-6a8f-7000-8000-00000000f000 --out day0.json",
        ),
    )
    fhir.add_argument("encounter_id", help="the encounter's id")
    fhir.add_argument("--out", required=True, help="the JSON file to write")
    fhir.set_defaults(func=lambda args: cmd_export_fhir(args, load(args)))
    dicom = export.add_parser(
        "dicom",
        help="the encounter as one DICOM study (photos, TID 1500 measurements, 3D surface, PDF report): files, a "
        "PACS over DICOMweb, or both; docs/dicom.md",
        **examples(
            "burnedge export dicom 0192f3b4-6a8f-7000-8000-00000000f000 --out study/",
            "burnedge export dicom 0192f3b4-6a8f-7000-8000-00000000f000 --to https://pacs.example.org/dicom-web",
            "burnedge --config burnedge.toml export dicom 0192f3b4-6a8f-7000-8000-00000000f000 --to config",
        ),
    )
    dicom.add_argument("encounter_id", help="the encounter's id")
    dicom.add_argument("--out", help="the folder to write the study's files (DICOM Part 10) in")
    dicom.add_argument(
        "--to",
        help='a DICOMweb root to store the study at (STOW-RS, checked with QIDO-RS), or "config" for [dicom] '
        "endpoint; the credentials are [dicom]'s",
    )
    dicom.set_defaults(func=lambda args: cmd_export_dicom(args, load(args)))
