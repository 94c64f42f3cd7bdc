"""The `burnedge` command line. Errors from any package are turned into messages and exit codes here."""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

import msgspec

from base import __version__
from burnedge import cli_analysis, cli_backup, cli_report, cli_sync, cli_users
from burnedge.cli_help import examples
from schemas.config import Config, load_config
from schemas.errors import AuthenticationFailed, BurnedgeError, Conflict, InvalidInput, NotFound

log = logging.getLogger("burnedge")

EXIT_CODES: list[tuple[type[BurnedgeError], int]] = [
    (InvalidInput, 2),
    (NotFound, 3),
    (Conflict, 4),
    (AuthenticationFailed, 5),
    (BurnedgeError, 1),
]


def _config(args: argparse.Namespace) -> Config:
    config = load_config(args.config)
    gateway = config.gateway
    overrides = {
        k: v
        for k, v in {
            "database": args.db,
            "host": getattr(args, "host", None),
            "port": getattr(args, "port", None),
        }.items()
        if v is not None
    }
    if overrides:
        gateway = msgspec.structs.replace(gateway, **overrides)
    return msgspec.structs.replace(config, gateway=gateway)


def cmd_serve(args: argparse.Namespace) -> int:
    from gateway.server import serve

    serve(_config(args))
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from burnedge.demo import demo_config, seed_demo
    from gateway.server import serve

    config = demo_config(_config(args))
    summary, passwords = seed_demo(config)
    print(summary, flush=True)
    if args.no_series:
        if not args.exit:
            serve(config)
        return 0
    from burnedge.demo_series import SeriesOptions, run_demo

    width, height = _size(args.size)
    folder = (
        Path(args.phantoms)
        if args.phantoms
        else Path(config.gateway.database).resolve().parent / "burnedge-demo-phantoms"
    )
    options = SeriesOptions(
        folder=folder, views=args.views, width=width, height=height, clinician_masks=args.clinician_masks
    )
    run_demo(config, options, passwords["clinician"], keep_serving=not args.exit)
    return 0


def _size(text: str) -> tuple[int, int]:
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError as exc:
        raise InvalidInput(f"--size {text}: give WIDTHxHEIGHT, e.g. 1280x960") from exc
    if not (320 <= width <= 8192 and 240 <= height <= 8192):
        raise InvalidInput(f"--size {text}: from 320x240 to 8192x8192")
    return width, height


def cmd_worker(args: argparse.Namespace) -> int:
    from gateway.jobs.worker import main as worker_main
    from gateway.reactions import ANALYSIS_STORED
    from gateway.storage.database import Database

    config = _config(args)
    db = Database.from_config(config.gateway)
    try:
        db.migrate()
    finally:
        db.close()
    ran = worker_main(config, supervised=False, drain=args.drain, reactions=ANALYSIS_STORED)
    log.info("worker stopped after %d analyses", ran)
    return 0


def cmd_audit_verify(args: argparse.Namespace) -> int:
    from gateway.records.audit_trail import verify
    from gateway.storage.database import Database

    config = _config(args)
    if not Path(config.gateway.database).exists():
        raise NotFound(f"no database at {config.gateway.database}")
    db = Database.from_config(config.gateway)
    try:
        result = verify(db, None, config)
    finally:
        db.close()
    print(json.dumps(msgspec.to_builtins(result)))
    return 0 if result.ok else 6


def cmd_schemas_export(args: argparse.Namespace) -> int:
    from schemas.export import export_json_schemas

    written = export_json_schemas(Path(args.dir))
    print(json.dumps({"dir": str(args.dir), "schemas": len(written)}))
    return 0


def cmd_gate(args: argparse.Namespace) -> int:
    from processing.capture.quality import gate_file

    config = _config(args).quality
    verdicts = []
    for name in args.files:
        if not Path(name).is_file():
            raise NotFound(f"no file {name}")
        verdicts.append(gate_file(name, config))
    print(msgspec.json.format(msgspec.json.encode(verdicts), indent=2).decode())
    return 0


def cmd_frames(args: argparse.Namespace) -> int:
    from processing.capture.frames import extract

    config = _config(args)
    video = Path(args.video)
    if not video.is_file():
        raise NotFound(f"no file {video}")
    result = extract(video, config.frames, config.quality, name=video.name)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    listing = []
    for frame in result.frames:
        name = f"{video.stem}_{frame.time_s:08.3f}s.jpg"
        (out / name).write_bytes(frame.jpeg)
        listing.append(
            {
                "file": name,
                "time_s": frame.time_s,
                "sharpness": frame.sharpness,
                "verdict": msgspec.to_builtins(msgspec.structs.replace(frame.verdict, file=name)),
            }
        )
    summary = {
        "video": str(video),
        "frames": listing,
        "decoded": result.decoded,
        "skipped_near_duplicates_s": result.skipped_duplicates,
        "seconds": round(result.seconds, 3),
    }
    (out / "frames.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(
        json.dumps(
            {"out": str(out), "frames": len(listing), "accepted": sum(f["verdict"]["accepted"] for f in listing)}
        )
    )
    return 0


def cmd_reconstruct(args: argparse.Namespace) -> int:
    from processing.reconstruction.pipeline import run
    from schemas.reconstruction import Outcome

    config = _config(args)
    ruler = cli_analysis.read_ruler(args.ruler)
    out, source = cli_analysis.prepare_out(args.source, args.out, args.fresh)
    report = run(config, source, out, ruler, gate=not args.no_gate)
    print(msgspec.json.format(msgspec.json.encode(report), indent=2).decode())
    if report.outcome is Outcome.failed:
        log.error("analysis failed: %s", report.reason)
        return 7
    return 0


def cmd_phantom(args: argparse.Namespace) -> int:
    from processing.phantom.generate import run, run_series
    from schemas.phantom import PhantomSpec

    given = {
        "shape": args.shape,
        "views": args.views,
        "width": args.width,
        "height": args.height,
        "seed": args.seed,
        "area_cm2": args.area_cm2,
        "depth_mm": args.depth_mm,
        "tone": args.tone,
        "burn_look": args.burn_look,
    }
    try:
        spec = msgspec.convert(
            {k: v for k, v in given.items() if v is not None} | {"exif": not args.no_exif}, PhantomSpec
        )
    except msgspec.ValidationError as exc:
        raise InvalidInput(f"{exc} (see `burnedge phantom --help` for the ranges)") from exc
    path = (run_series if args.series else run)(spec, Path(args.out))
    print(json.dumps({"out": str(args.out), "ground_truth": str(path)}))
    return 0


def _global_options(parser: argparse.ArgumentParser, default) -> None:
    parser.add_argument("--config", default=default, help="TOML configuration file (see docs/configuration.md)")
    parser.add_argument("--db", default=default, help="SQLite database file (overrides the configuration)")
    parser.add_argument("-v", "--verbose", action="store_true", default=default, help="log debug messages")


def _global_options_after_commands(parser: argparse.ArgumentParser) -> None:
    """`burnedge serve --db X` as well as `burnedge --db X serve`: each command accepts the global options too. Their
    default there is SUPPRESS, so an option given before the command is not reset by its absence after it."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for command in action.choices.values():
                if any(isinstance(a, argparse._SubParsersAction) for a in command._actions):
                    _global_options_after_commands(command)
                else:
                    _global_options(command, argparse.SUPPRESS)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="burnedge",
        description="Objective burn assessment at the clinic edge.",
        **examples(
            "burnedge demo",
            "burnedge serve --host 0.0.0.0",
            "burnedge users add --username admin --role admin",
            "burnedge --config /etc/burnedge/burnedge.toml audit verify",
            "burnedge COMMAND --help   # each command's options and examples",
        ),
    )
    _global_options(parser, None)
    parser.add_argument("--version", action="version", version=f"burnedge {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    serve = sub.add_parser(
        "serve",
        help="run the gateway HTTP API",
        **examples(
            "burnedge serve",
            "burnedge serve --host 0.0.0.0 --port 8080   # phones on the clinic network",
            "burnedge --config /etc/burnedge/burnedge.toml serve",
        ),
    )
    serve.add_argument(
        "--host", help="address to listen on (default [gateway] host, 127.0.0.1; 0.0.0.0 for the clinic network)"
    )
    serve.add_argument("--port", type=int, help="TCP port (default [gateway] port, 8080)")
    serve.set_defaults(func=cmd_serve)

    demo = sub.add_parser(
        "demo",
        help="the whole system on this machine: demo patients, a 4-visit burn series "
        "uploaded, analysed and aligned through the real gateway, then serve it",
        **examples(
            "burnedge demo", "burnedge demo --exit --views 6 --size 960x720", "burnedge demo --no-series --port 8081"
        ),
    )
    demo.add_argument("--host", help="address to listen on")
    demo.add_argument("--port", type=int, help="TCP port (default 8080)")
    demo.add_argument(
        "--exit",
        "--no-serve",
        dest="exit",
        action="store_true",
        help="exit after the summary instead of leaving the gateway running",
    )
    demo.add_argument("--no-series", action="store_true", help="seed the records only; no phantom series or analyses")
    demo.add_argument("--views", type=int, default=8, help="photos per visit, 6-20 (default 8)")
    demo.add_argument("--size", default="1280x960", help="photo size WIDTHxHEIGHT (default 1280x960)")
    demo.add_argument("--phantoms", metavar="DIR", help="where the rendered series is kept (burnedge-demo-phantoms)")
    demo.add_argument(
        "--clinician-masks",
        action="store_true",
        help="send the phantom's exact burn masks as a clinician's instead of using the model",
    )
    demo.set_defaults(func=cmd_demo)

    worker = sub.add_parser(
        "worker",
        help="run queued analyses (beside a gateway started with [jobs] workers = 0)",
        **examples("burnedge worker", "burnedge --config /etc/burnedge/burnedge.toml worker --drain"),
    )
    worker.add_argument("--drain", action="store_true", help="exit once no queued analysis is ready to run")
    worker.set_defaults(func=cmd_worker)

    gate = sub.add_parser(
        "gate",
        help="quality verdicts for photos, as JSON (no server needed)",
        **examples("burnedge gate IMG_0412.jpg", "burnedge gate visit1/*.jpg"),
    )
    gate.add_argument("files", nargs="+", metavar="FILE", help="JPEG, PNG or HEIC photos")
    gate.set_defaults(func=cmd_gate)

    frames = sub.add_parser(
        "frames",
        help="extract a multi-view set of frames from a video (no server needed)",
        **examples("burnedge frames arm.mp4 --out arm-frames"),
    )
    frames.add_argument("video", metavar="VIDEO", help="MP4 or MOV, H.264 or HEVC")
    frames.add_argument("--out", required=True, metavar="DIR", help="folder for the frames and frames.json")
    frames.set_defaults(func=cmd_frames)

    rec = sub.add_parser(
        "reconstruct",
        help="photos or a video -> scaled 3D surface mesh (PLY, GLB) and report",
        **examples(
            "burnedge reconstruct visit1/ --out visit1-3d",
            "burnedge reconstruct arm.mp4 --out arm-3d --ruler ruler.json --fresh",
        ),
    )
    rec.add_argument("source", metavar="SOURCE", help="folder of photos, or a video (MP4, MOV)")
    rec.add_argument("--out", required=True, metavar="DIR", help="analysis folder; an interrupted run resumes there")
    rec.add_argument("--ruler", metavar="FILE", help="JSON with two ruler points marked in 2+ pictures (no marker)")
    rec.add_argument("--fresh", action="store_true", help="discard what an earlier run left in DIR")
    rec.add_argument(
        "--no-gate",
        action="store_true",
        help="use every decodable picture, even those the burn-photo quality gate rejects",
    )
    rec.set_defaults(func=cmd_reconstruct)

    cli_analysis.add_commands(sub, _config)
    cli_sync.add_commands(sub, _config)
    cli_backup.add_commands(sub, _config)
    cli_users.add_commands(sub, _config)
    cli_report.add_commands(sub, _config)

    phantom = sub.add_parser(
        "phantom",
        help="render a burn phantom: multi-view photos with exact ground truth",
        **examples(
            "burnedge phantom --out phantom1",
            "burnedge phantom --out series --series",
            "burnedge phantom --out foot --shape foot --views 8 --tone V --area-cm2 20",
        ),
    )
    phantom.add_argument("--out", required=True, metavar="DIR", help="folder for images/, masks/, ground_truth.json")
    phantom.add_argument("--shape", choices=["forearm", "patch", "foot"], help="body part (default forearm)")
    phantom.add_argument("--views", type=int, help="number of photos, 6-20 (default 12)")
    phantom.add_argument("--width", type=int, help="image width in pixels (default 1920)")
    phantom.add_argument("--height", type=int, help="image height in pixels (default 1440)")
    phantom.add_argument("--seed", type=int, help="seed of every random choice (default 0)")
    phantom.add_argument("--area-cm2", type=float, help="burn area, 1-40 cm2 (default 14)")
    phantom.add_argument("--depth-mm", type=float, help="crater depth, 0-8 mm; 0 is a flat burn (default 2)")
    phantom.add_argument("--tone", choices=["I", "II", "III", "IV", "V", "VI"], help="skin type (default III)")
    phantom.add_argument(
        "--burn-look",
        choices=["mixed", "superficial", "deep_partial", "full_thickness"],
        help="colour and texture of the burn (default mixed)",
    )
    phantom.add_argument("--series", action="store_true", help="four sessions (days 0, 7, 14, 21) of a healing burn")
    phantom.add_argument("--no-exif", action="store_true", help="leave the focal length out of the JPEGs' EXIF")
    phantom.set_defaults(func=cmd_phantom)

    audit = sub.add_parser("audit", help="the audit trail", **examples("burnedge audit verify")).add_subparsers(
        dest="audit_cmd", required=True
    )
    verify = audit.add_parser(
        "verify",
        help="check the hash chain; names the first broken entry (exit 6)",
        **examples("burnedge audit verify", "burnedge --config /etc/burnedge/burnedge.toml audit verify"),
    )
    verify.set_defaults(func=cmd_audit_verify)

    schemas = sub.add_parser("schemas", help="message schemas", **examples("burnedge schemas export json-schemas"))
    schemas = schemas.add_subparsers(dest="schemas_cmd", required=True)
    export = schemas.add_parser(
        "export", help="write JSON Schema for every public message", **examples("burnedge schemas export json-schemas")
    )
    export.add_argument("dir", help="output folder")
    export.set_defaults(func=cmd_schemas_export)
    _global_options_after_commands(parser)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(
        level=logging.DEBUG if args.verbose else logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    if not args.verbose:  # every scheduler tick and every HTTP request of the demo's client would be logged
        for chatty in ("apscheduler", "httpx", "fontTools"):
            logging.getLogger(chatty).setLevel(logging.WARNING)
    try:
        return args.func(args)
    except BurnedgeError as exc:
        print(f"burnedge: error: {exc.detail}", file=sys.stderr)
        return next(code for cls, code in EXIT_CODES if isinstance(exc, cls))
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    raise SystemExit(main())
