"""The analysis commands of the CLI: segment, analyze, track, train-segmentation."""

from __future__ import annotations

import argparse
import logging
import os
import sys
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

import msgspec

from burnedge.cli_help import examples
from schemas.base import counted
from schemas.config import Config
from schemas.errors import InvalidInput, NotFound

log = logging.getLogger("burnedge")

IMAGE_SUFFIXES = {".jpg", ".jpeg", ".png", ".heic", ".heif"}


@contextmanager
def native_stdout_to_stderr():
    """Native libraries (Open3D's warnings, COLMAP) write to file descriptor 1; while they work, that goes to stderr,
    so what the command prints on stdout afterwards is its JSON answer alone."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        os.dup2(2, 1)
        yield
    finally:
        sys.stdout.flush()
        os.dup2(saved, 1)
        os.close(saved)


def read_ruler(path: str | None):
    """The ruler points file given on the command line, or None when none was given."""
    from schemas.reconstruction import RulerPoints

    if not path:
        return None
    try:
        return msgspec.json.decode(Path(path).read_bytes(), type=RulerPoints)
    except FileNotFoundError as exc:
        raise NotFound(f"no ruler file {path}") from exc
    except (msgspec.ValidationError, msgspec.DecodeError) as exc:
        raise InvalidInput(f"ruler file {path}: {exc}") from exc


def prepare_out(source_arg: str, out_arg: str, fresh: bool) -> tuple[Path, Path]:
    """(out, source) resolved; refuses an analysis folder inside the pictures; --fresh empties an old one."""
    import shutil

    out, source = Path(out_arg).resolve(), Path(source_arg).resolve()
    if out == source or out in source.parents or source in out.parents:
        raise InvalidInput(f"--out {out_arg} overlaps the pictures in {source_arg}; choose a separate folder")
    if fresh and out.exists():
        if any(out.iterdir()) and not ((out / "inputs.json").exists() or (out / "report.json").exists()):
            raise InvalidInput(f"--fresh: {out_arg} does not look like an analysis folder; not deleting it")
        shutil.rmtree(out)
    return out, source


def cmd_segment(args: argparse.Namespace, config: Config) -> int:
    import cv2
    import numpy as np

    from processing.segmentation.infer import BurnSegmenter, read_rgb

    if not Path(args.source).is_dir():
        raise NotFound(f"{args.source} is not a folder of photos")
    out, source = prepare_out(args.source, args.out, fresh=False)
    photos = sorted(p for p in source.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
    if not photos:
        raise InvalidInput(f"{source} holds no JPEG, PNG or HEIC photos")
    stems = [p.stem for p in photos]
    if len(set(stems)) < len(stems):
        twins = sorted({s for s in stems if stems.count(s) > 1})
        raise InvalidInput(
            f"photos share a name but not a type ({', '.join(twins)}): their masks would overwrite "
            "each other; rename one of each"
        )
    out.mkdir(parents=True, exist_ok=True)
    segmenter = BurnSegmenter(config.analysis.model, config.analysis.threads)
    for i, photo in enumerate(photos, 1):
        rgb = read_rgb(photo)
        prob = segmenter.probability(rgb)
        for name, image in (
            (f"{photo.stem}.png", np.where(prob >= 0.5, 255, 0).astype(np.uint8)),
            (f"{photo.stem}.probability.png", np.round(prob * 255).astype(np.uint8)),
        ):
            tmp = out / f".{name}.tmp.png"
            if not cv2.imwrite(str(tmp), image):
                raise InvalidInput(f"could not write {out / name} (disk full or not writable?)")
            tmp.replace(out / name)
        log.info("[%d/%d] %s: burn in %.1f %% of the picture", i, len(photos), photo.name, 100 * (prob >= 0.5).mean())
    return 0


def cmd_analyze(args: argparse.Namespace, config: Config) -> int:
    from processing.analysis.pipeline import Patient, run
    from schemas.analysis import AnalysisStatus

    if args.marker_mm is not None:
        if not 0 < args.marker_mm <= 500:
            raise InvalidInput(f"--marker-mm {args.marker_mm:g}: the printed marker's side must be in (0, 500] mm")
        config = msgspec.structs.replace(
            config, reconstruction=msgspec.structs.replace(config.reconstruction, marker_side_mm=args.marker_mm)
        )
    ruler = read_ruler(args.ruler)
    masks = Path(args.masks) if args.masks else None
    if masks is not None and not masks.is_dir():
        raise NotFound(f"--masks {args.masks} is not a folder")
    out, source = prepare_out(args.source, args.out, args.fresh)
    patient = Patient(hours_since_injury=args.hours_since_injury, height_cm=args.height_cm, weight_kg=args.weight_kg)
    with native_stdout_to_stderr():
        result = run(config, source, out, masks=masks, ruler=ruler, patient=patient, gate=not args.no_gate)
    print(msgspec.json.format(msgspec.json.encode(result), indent=2).decode())
    if result.status is AnalysisStatus.failed:
        log.error("analysis failed: %s", result.reason)
        return 7
    return 0


def parse_days(text: str, count: int) -> list[float]:
    """--days: one day per visit, comma-separated, never decreasing."""
    try:
        days = [float(part) for part in text.split(",") if part.strip()]
    except ValueError as exc:
        raise InvalidInput(f"--days {text}: give numbers separated by commas, e.g. 0,7,14,21") from exc
    if len(days) != count:
        raise InvalidInput(
            f"--days {text}: {counted(len(days), 'day')} for {counted(count, 'visit folder')}; give one day per visit"
        )
    if any(not 0 <= d < 10_000 for d in days):
        raise InvalidInput(f"--days {text}: days count from the injury (or the first visit) and must be 0 or more")
    for earlier, later in zip(days, days[1:], strict=False):
        if later < earlier:
            raise InvalidInput(
                f"--days {text}: days must not decrease (day {later:g} after day {earlier:g}); give "
                "the visit folders in time order"
            )
    return days


def cmd_track(args: argparse.Namespace, config: Config) -> int:
    import shutil

    from processing.analysis.pipeline import Patient
    from processing.analysis.pipeline import run as analyze
    from processing.longitudinal import track
    from schemas.longitudinal import TrackResult

    days = parse_days(args.days, len(args.sessions))
    out = Path(args.out).resolve()
    visits = []
    for folder in args.sessions:
        source = Path(folder).resolve()
        if not source.is_dir():
            raise NotFound(f"{folder} is not a folder of one visit's photos")
        if out == source or out in source.parents or source in out.parents:
            raise InvalidInput(f"--out {args.out} overlaps the visit folder {folder}; choose a separate folder")
        images = source / "images" if (source / "images").is_dir() else source
        masks = source / "masks" if (source / "masks").is_dir() else None
        visits.append((images, masks))
    if args.fresh and out.exists():
        if any(out.iterdir()) and not ((out / track.RESULT).exists() or (out / "sessions").is_dir()):
            raise InvalidInput(f"--fresh: {args.out} does not look like a track folder; not deleting it")
        shutil.rmtree(out)
    sessions = []
    with native_stdout_to_stderr():
        for i, (day, (images, masks)) in enumerate(zip(days, visits, strict=True)):
            folder = out / "sessions" / f"{i:02d}_day{day:g}"
            log.info("visit %d of %d (day %g): analysing %s", i + 1, len(visits), day, images)
            result = analyze(config, images, folder, masks=masks, patient=Patient(hours_since_injury=day * 24))
            if result.status.value == "failed":
                log.warning("visit %d (day %g) failed: %s", i + 1, day, result.reason)
            sessions.append(track.SessionAnalysis(day=day, analysis_dir=folder, label=Path(args.sessions[i]).name))
        path = track.run(config.tracking, sessions, out)
    print(path.read_text())
    if not any(s.baseline for s in msgspec.json.decode(path.read_bytes(), type=TrackResult).sessions):
        log.error("no visit could be measured in real units: nothing to track")
        return 7
    return 0


def cmd_train_segmentation(args: argparse.Namespace, config: Config) -> int:
    try:
        from processing.segmentation.train import run
    except ImportError as exc:
        raise InvalidInput(f"training needs torch and onnx: pip install -e '.[train]' ({exc})") from exc
    from schemas.segmentation import TrainingConfig

    conf = TrainingConfig()
    if args.recipe:
        try:
            conf = msgspec.json.decode(Path(args.recipe).read_bytes(), type=TrainingConfig)
        except (OSError, msgspec.ValidationError, msgspec.DecodeError) as exc:
            raise InvalidInput(f"training recipe {args.recipe}: {exc}") from exc
    if args.epochs:
        conf = msgspec.structs.replace(conf, epochs=args.epochs)
    if args.encoder:
        conf = msgspec.structs.replace(conf, encoder=args.encoder)
    cache = Path(args.cache or Path(args.out) / "phantoms")
    report = run(conf, Path(args.data), Path(args.out), cache, max_minutes=args.max_minutes)
    print(report.read_text())
    return 0


def add_commands(sub, config_of: Callable[[argparse.Namespace], Config]) -> None:
    """Registers the commands; each is called with its parsed arguments and the loaded configuration."""

    def bind(func):
        return lambda args: func(args, config_of(args))

    seg = sub.add_parser(
        "segment",
        help="the burn segmentation model alone: one PNG mask per photo",
        **examples("burnedge segment visit1/ --out visit1-masks"),
    )
    seg.add_argument("source", metavar="DIR", help="folder of photos")
    seg.add_argument(
        "--out", required=True, metavar="OUT", help="folder for STEM.png (255 = burn) and STEM.probability.png"
    )
    seg.set_defaults(func=bind(cmd_segment))

    ana = sub.add_parser(
        "analyze",
        help="photos or a video -> burn area, perimeter, relief, volume (analysis.json)",
        **examples(
            "burnedge analyze visit1/ --out visit1-analysis",
            "burnedge analyze visit1/ --out visit1-analysis --masks visit1-outlines/ "
            "--hours-since-injury 30 --height-cm 160 --weight-kg 55",
        ),
    )
    ana.add_argument("source", metavar="DIR", help="folder of photos, or a video (MP4, MOV)")
    ana.add_argument("--out", required=True, metavar="OUT", help="analysis folder; an interrupted run resumes there")
    ana.add_argument(
        "--masks",
        metavar="DIR",
        help="a person's burn masks (STEM.png, white = burn) or outlines (STEM.json); they replace "
        "the model's for those pictures",
    )
    ana.add_argument("--marker-mm", type=float, help="printed side of each marker square in mm (default 20)")
    ana.add_argument("--ruler", metavar="FILE", help="JSON with two ruler points marked in 2+ pictures (no marker)")
    ana.add_argument("--hours-since-injury", type=float, help="before 72 h the result is marked provisional")
    ana.add_argument("--height-cm", type=float, help="patient height, for %%TBSA of this burn")
    ana.add_argument("--weight-kg", type=float, help="patient weight, for %%TBSA of this burn")
    ana.add_argument("--fresh", action="store_true", help="discard what an earlier run left in OUT")
    ana.add_argument("--no-gate", action="store_true", help="use every decodable picture, even rejected ones")
    ana.set_defaults(func=bind(cmd_analyze))

    trk = sub.add_parser(
        "track",
        help="a burn's visits over time -> changes, healing rate, prompts (track.json)",
        **examples("burnedge track day0/ day7/ day14/ day21/ --days 0,7,14,21 --out healing"),
    )
    trk.add_argument(
        "sessions",
        nargs="+",
        metavar="SESSION_DIR",
        help="one folder per visit, in time order: its photos, or images/ with an optional masks/ "
        "(a person's masks, STEM.png)",
    )
    trk.add_argument(
        "--days",
        required=True,
        metavar="D,D,...",
        help="day of each visit since the injury (or the first visit), e.g. 0,7,14,21",
    )
    trk.add_argument(
        "--out",
        required=True,
        metavar="OUT",
        help="folder for each visit's analysis (sessions/NN_dayD), the registrations and track.json; "
        "an interrupted run resumes there",
    )
    trk.add_argument("--fresh", action="store_true", help="discard what an earlier run left in OUT")
    trk.set_defaults(func=bind(cmd_track))

    train = sub.add_parser(
        "train-segmentation",
        help="train the segmentation model on the CPU, export ONNX",
        **examples(
            "burnedge train-segmentation --out model/",
            "burnedge train-segmentation --out model/ --recipe recipe.json --epochs 2",
        ),
    )
    train.add_argument(
        "--data",
        default="../shared/datasets/fuseg2021-train",
        metavar="DIR",
        help="wound photos with images/ and masks/ (default ../shared/datasets/fuseg2021-train)",
    )
    train.add_argument("--out", required=True, metavar="DIR", help="folder for burnseg.onnx and its training report")
    train.add_argument("--cache", metavar="DIR", help="where the rendered training phantoms are kept (OUT/phantoms)")
    train.add_argument("--recipe", metavar="FILE", help="JSON training recipe (see schemas/segmentation.py)")
    train.add_argument("--epochs", type=int, help="override the recipe's number of epochs")
    train.add_argument(
        "--encoder",
        choices=["plain", "efficientnet-lite0"],
        help="the network: the small U-Net from scratch (plain) or on ImageNet-pretrained EfficientNet-Lite0",
    )
    train.add_argument(
        "--max-minutes",
        type=float,
        metavar="M",
        help="stop before an epoch that would end after M minutes (the checkpoint keeps it; run again to go on)",
    )
    train.set_defaults(func=bind(cmd_train_segmentation))
