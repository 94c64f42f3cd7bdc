"""Stage 0: collect the usable pictures (photos from a folder, or frames from a video) into the analysis folder.

The source is only read: pictures are hard-linked (or copied) under images/, HEIC photos are
converted to JPEG there, and every picture the quality gate rejects is listed with its reasons.
"""

from __future__ import annotations

import logging
import os
import shutil
from pathlib import Path

from processing.capture.frames import extract
from processing.capture.quality import gate_file
from processing.stages import fresh_dir, publish_dir, write_json
from schemas.config import Config
from schemas.errors import CaptureInsufficient, NotFound
from schemas.reconstruction import FailureCode, InputSet, SkippedPicture

log = logging.getLogger(__name__)

RECORD = "inputs.json"
IMAGES = "images"
PHOTO_SUFFIXES = {".jpg", ".jpeg", ".png"}
HEIF_SUFFIXES = {".heic", ".heif"}
VIDEO_SUFFIXES = {".mp4", ".mov", ".m4v"}


def run(config: Config, source: Path, out_dir: Path, *, gate: bool = True) -> Path:
    """Write out_dir/images/ and out_dir/inputs.json; returns the record's path.

    `gate=False` keeps every decodable picture (a set vetted elsewhere, or a non-clinical test set
    the burn-photo quality gate would misjudge).
    """
    if not source.exists():
        raise NotFound(f"{source} does not exist")
    tmp = fresh_dir(out_dir / (IMAGES + ".tmp"))
    if source.is_file() and source.suffix.lower() in VIDEO_SUFFIXES:
        record = _from_video(config, source, tmp, gate)
    elif source.is_dir():
        record = _from_folder(config, source, tmp, gate)
    else:
        raise CaptureInsufficient(
            f"{source.name} is neither a folder of photos nor a video (.mp4, .mov)", code=FailureCode.no_pictures
        )
    if not record.pictures:
        shutil.rmtree(tmp, ignore_errors=True)
        raise CaptureInsufficient(
            f"no usable pictures in {source}" + _why(record.skipped), code=FailureCode.no_pictures
        )
    publish_dir(tmp, out_dir / IMAGES)
    return write_json(out_dir / RECORD, record)


def _from_folder(config: Config, folder: Path, images: Path, gate: bool) -> InputSet:
    pictures, skipped = [], []
    for path in sorted(p for p in folder.iterdir() if p.is_file() and not p.name.startswith(".")):
        suffix = path.suffix.lower()
        if suffix not in PHOTO_SUFFIXES | HEIF_SUFFIXES:
            if suffix not in {".json", ".txt", ".md"}:
                skipped.append(SkippedPicture(name=path.name, reasons=["unsupported"]))
            continue
        verdict = gate_file(path, config.quality)
        if verdict.figures is None or (gate and not verdict.accepted):
            skipped.append(SkippedPicture(name=path.name, reasons=[r.value for r in verdict.reasons]))
            continue
        if suffix in HEIF_SUFFIXES:
            target = images / (path.name + ".jpg")  # X.heic -> X.heic.jpg: cannot clash with a real X.jpg
            _heif_to_jpeg(path, target)
        else:
            target = images / path.name
            _link_or_copy(path, target)
        pictures.append(target.name)
    return InputSet(source=str(folder), video=False, pictures=pictures, skipped=skipped)


def _from_video(config: Config, video: Path, images: Path, gate: bool) -> InputSet:
    result = extract(video, config.frames, config.quality, name=video.name)
    pictures, skipped = [], []
    for index, frame in enumerate(result.frames):
        name = f"frame_{index:03d}_{frame.time_s:07.2f}s.jpg"
        if gate and not frame.verdict.accepted:
            skipped.append(SkippedPicture(name=name, reasons=[r.value for r in frame.verdict.reasons]))
            continue
        (images / name).write_bytes(frame.jpeg)
        pictures.append(name)
    return InputSet(source=str(video), video=True, pictures=pictures, skipped=skipped)


def _link_or_copy(source: Path, target: Path) -> None:
    try:
        os.link(source, target)
    except OSError:
        shutil.copy2(source, target)


def _heif_to_jpeg(source: Path, target: Path) -> None:
    import pillow_heif
    from PIL import Image

    pillow_heif.register_heif_opener()
    with Image.open(source) as image:
        exif = image.getexif()
        exif[0x0112] = 1  # pixels are written upright below, so the orientation tag must say so
        image.convert("RGB").save(target, "JPEG", quality=95, exif=exif.tobytes())


def _why(skipped: list[SkippedPicture]) -> str:
    if not skipped:
        return ""
    shown = "; ".join(f"{s.name}: {', '.join(s.reasons)}" for s in skipped[:5])
    return f" ({shown}{'; ...' if len(skipped) > 5 else ''})"
