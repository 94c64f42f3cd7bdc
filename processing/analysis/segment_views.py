"""Stage: a burn mask and probability map for every placed picture; a person's mask wins over the model.

    run(conf, images_dir, pictures, out_dir, masks_dir, boxes) -> out_dir/segmentation.json

A person's mask is `<stem>.png` (white = burn) or `<stem>.json` with outline polygons
(`{"polygons": [[[x, y], ...], ...]}`, pixels of the picture as stored) in `masks_dir`.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import cv2
import msgspec
import numpy as np

from processing.analysis import outline_checks
from processing.reconstruction.views import read_rgb
from processing.segmentation import passes
from processing.segmentation.infer import Box, BurnSegmenter, fairness_of
from processing.stages import fresh_dir, publish_dir, write_json
from schemas.analysis import ModelSummary, SegmentationRecord, ViewMask
from schemas.config import AnalysisConfig
from schemas.errors import InvalidInput
from schemas.segmentation import MaskSource

log = logging.getLogger(__name__)

RECORD = "segmentation.json"
OVERLAY_COLOUR = np.array([255, 40, 200], np.float32)  # magenta: distinct from red burns and all skin tones


def person_mask(masks_dir: Path, stem: str, shape: tuple[int, int]) -> tuple[np.ndarray, MaskSource]:
    """The mask a person gave for this picture (bool): STEM.png, else the outline STEM.json."""
    png, outline = masks_dir / f"{stem}.png", masks_dir / f"{stem}.json"
    if png.exists():
        mask = cv2.imread(str(png), cv2.IMREAD_GRAYSCALE)
        if mask is None:
            raise InvalidInput(f"{png}: not a readable PNG mask")
        if mask.shape != shape:
            raise InvalidInput(
                f"{png}: mask is {mask.shape[1]}x{mask.shape[0]} but the picture is "
                f"{shape[1]}x{shape[0]}; draw the mask on the picture as stored"
            )
        return mask >= 128, MaskSource.clinician_mask
    if outline.exists():
        try:
            polygons = json.loads(outline.read_text())["polygons"]
            rings = [np.round(np.asarray(p, np.float64)).astype(np.int32).reshape(-1, 2) for p in polygons]
        except (KeyError, TypeError, ValueError) as exc:
            raise InvalidInput(f'{outline}: expected {{"polygons": [[[x, y], ...], ...]}} ({exc})') from exc
        if not rings or any(len(r) < 3 for r in rings):
            raise InvalidInput(f"{outline}: every outline needs at least 3 points")
        mask = np.zeros(shape, np.uint8)
        cv2.fillPoly(mask, rings, 255)
        return mask > 0, MaskSource.clinician_outline
    raise InvalidInput(f"no mask {png.name} or outline {outline.name} in {masks_dir}")


def overlay(rgb: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """The picture with the burn tinted and its edge drawn, as BGR for writing."""
    out = rgb.astype(np.float32)
    out[mask] = 0.6 * out[mask] + 0.4 * OVERLAY_COLOUR
    out = cv2.cvtColor(out.astype(np.uint8), cv2.COLOR_RGB2BGR)
    contours, _ = cv2.findContours(mask.astype(np.uint8), cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    cv2.drawContours(out, contours, -1, (200, 40, 255), max(2, rgb.shape[1] // 640))
    return out


def _write(path: Path, image: np.ndarray, *params: int) -> None:
    if not cv2.imwrite(str(path), image, list(params)):
        raise OSError(f"could not write {path} (disk full or not writable?)")


def _mask_stems(masks_dir: Path | None) -> set[str]:
    if masks_dir is None:
        return set()
    return {f.stem for f in masks_dir.iterdir() if f.suffix.lower() in (".png", ".json")}


def _given_stem(name: str, given: set[str]) -> str | None:
    """The stem a person's mask for this picture would carry: `X` for `X.jpg`, and for `X.heic.jpg` (a HEIC
    photo converted for the analysis) `X.heic` or `X`."""
    stem = Path(name).stem
    return next((s for s in (stem, Path(stem).stem) if s in given), None)


def _edge_touched(mask: np.ndarray, seen: np.ndarray) -> bool:
    """Whether the largest burn region reaches the edge of what the model looked at (`seen`: its first
    square and its second, which may reach past the first) where that is not also the picture's own edge
    (specks elsewhere, on the drape say, do not count)."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    if count < 2:
        return False
    burn = labels == 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    inside = seen.astype(np.uint8)
    # pixels outside the picture count as seen, so its own edge is never the edge of the look
    eroded = cv2.erode(inside, np.ones((3, 3), np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=1)
    return bool((burn & (inside > eroded)).any())


def _model_mask(
    segmenter: BurnSegmenter, rgb: np.ndarray, box: Box | None, tmp: Path, stem: str
) -> tuple[np.ndarray, MaskSource, dict]:
    """The model's mask of one picture, its probability map written (rescaled: the model's threshold at
    0.5), and the ViewMask fields that say how sure the outline is."""
    two = segmenter.segment(rgb, box)
    threshold = segmenter.settings.threshold
    checks = outline_checks.view_checks(rgb, two, threshold, box, segmenter.settings.fine_size)
    prob = passes.rescaled(two.probability, threshold, two.looked_at(), in_place=True)
    mask = prob >= 0.5
    extra = {"probability": f"probability/{stem}.png"}
    _write(tmp / extra["probability"], np.round(prob * 255).astype(np.uint8))
    if box is not None:
        extra |= {"crop": [box.x0, box.y0, box.side], "burn_at_crop_edge": _edge_touched(mask, two.seen())}
    if two.fine_square is not None:
        extra["fine_square"] = [two.fine_square.x0, two.fine_square.y0, two.fine_square.side]
    return mask, MaskSource.model, extra | checks


def model_summary(segmenter: BurnSegmenter) -> ModelSummary:
    """What the segmentation record keeps of the model: version, hash, threshold, fairness table."""
    return ModelSummary(
        version=segmenter.metadata.get("version", ""),
        sha256=segmenter.sha256,
        threshold=segmenter.settings.threshold,
        fairness=fairness_of(segmenter.metadata),
        architecture=segmenter.metadata.get("architecture", ""),
    )


def run(
    conf: AnalysisConfig,
    images_dir: Path,
    pictures: list[str],
    out_dir: Path,
    masks_dir: Path | None = None,
    boxes: dict[str, Box] | None = None,
    segmenter: BurnSegmenter | None = None,
) -> Path:
    """Writes the masks, probabilities and overlays into a fresh folder, then puts it in place of out_dir."""
    if masks_dir is not None and not masks_dir.is_dir():
        raise InvalidInput(f"--masks {masks_dir} is not a folder")
    given = _mask_stems(masks_dir)
    tmp = fresh_dir(out_dir.with_name(out_dir.name + ".tmp"))
    for sub in ("masks", "probability", "overlays"):
        (tmp / sub).mkdir()
    records, used = [], set()
    for name in pictures:
        stem = Path(name).stem
        rgb = read_rgb(images_dir / name)
        person_stem = _given_stem(name, given)
        box = (boxes or {}).get(name)
        extra = {}
        if person_stem is not None:
            used.add(person_stem)
            mask, source = person_mask(masks_dir, person_stem, rgb.shape[:2])
        else:
            segmenter = segmenter or BurnSegmenter(conf.model, conf.threads)
            mask, source, extra = _model_mask(segmenter, rgb, box, tmp, stem)
        _write(tmp / "masks" / f"{stem}.png", mask.astype(np.uint8) * 255)
        _write(tmp / "overlays" / f"{stem}.jpg", overlay(rgb, mask), cv2.IMWRITE_JPEG_QUALITY, 85)
        records.append(
            ViewMask(
                image=name,
                source=source,
                burn_pixels=int(mask.sum()),
                mask=f"masks/{stem}.png",
                overlay=f"overlays/{stem}.jpg",
                **extra,
            )
        )
        log.info("segmented %s (%s, %d burn pixels)", name, source.value, records[-1].burn_pixels)
    record = SegmentationRecord(
        views=records,
        unmatched_masks=sorted(given - used),
        model=model_summary(segmenter) if segmenter and any(r.source is MaskSource.model for r in records) else None,
    )
    write_json(tmp / RECORD, msgspec.to_builtins(record))
    publish_dir(tmp, out_dir)
    return out_dir / RECORD
