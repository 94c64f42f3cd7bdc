"""The report and export commands of the CLI: an encounter's clinical report (PDF), or the encounter as a FHIR
R4 Bundle, written to a file."""

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
