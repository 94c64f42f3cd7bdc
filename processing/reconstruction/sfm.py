"""Stage 1: Structure from Motion with pycolmap (SIFT, matching suited to the input, incremental mapping)."""

from __future__ import annotations

import logging
from pathlib import Path

import cv2
import msgspec
import numpy as np
import pycolmap

from processing.reconstruction.sfm_checks import check_model, pair_graph, quality_record
from processing.stages import fresh_dir, publish_dir, write_json
from schemas.config import ReconstructionConfig
from schemas.errors import CaptureInsufficient
from schemas.reconstruction import FailureCode, SfmQuality

log = logging.getLogger(__name__)

QUALITY = "sfm_quality.json"
MODEL = "model"
THOROUGH = {
    "sift_first_octave": -1,
    "sift_max_features": 16384,
    "guided_matching": True,
    "min_pose_inliers": 15,
    "min_pose_inlier_ratio": 0.1,
}
"""Settings of the second attempt, for weakly textured sets or pictures taken far apart: on the real
skull photos they place 33 of 33 where the fast defaults place 14 (at about 20 times the cost)."""


def run(conf: ReconstructionConfig, images_dir: Path, names: list[str], out_dir: Path, *, video: bool) -> Path:
    """Place the pictures; writes out_dir/model (COLMAP binary) and out_dir/sfm_quality.json, returns the model path.

    Raises CaptureInsufficient when too few pictures can be placed, they come from one spot, or they
    show more than one scene.
    """
    if len(names) < conf.min_views:
        raise CaptureInsufficient(
            f"only {len(names)} usable pictures; at least {conf.min_views} are needed, "
            "taken while walking around the burn",
            code=FailureCode.too_few_views,
        )
    try:
        model, quality, database = _attempt(conf, images_dir, names, out_dir, video=video, thorough=False)
    except CaptureInsufficient as exc:
        if exc.code != FailureCode.too_few_placed or not conf.thorough_retry:
            raise
        log.info("SfM placed too few pictures (%s); trying once more with thorough settings", exc.detail)
        model, quality, database = _attempt(
            msgspec.structs.replace(conf, **THOROUGH), images_dir, names, out_dir, video=video, thorough=True
        )
    tmp = fresh_dir(out_dir / (MODEL + ".tmp"))
    model.write_binary(str(tmp))
    publish_dir(tmp, out_dir / MODEL)
    # The database stays beside the model so COLMAP's GUI can open both.
    database.replace(out_dir / "database.db")
    write_json(out_dir / QUALITY, quality)
    log.info("SfM placed %d of %d pictures", quality.images_registered, quality.images_used)
    return out_dir / MODEL


def _attempt(
    conf: ReconstructionConfig, images_dir: Path, names: list[str], out_dir: Path, *, video: bool, thorough: bool
) -> tuple[pycolmap.Reconstruction, SfmQuality, Path]:
    work = fresh_dir(out_dir / "work")
    database = work / "database.db"
    extract(conf, images_dir, names, database)
    matching = match(conf, names, images_dir, database, work, video=video)
    models = incremental_map(conf, images_dir, names, database, work / "models")
    graph = pair_graph(database)
    model, angle = check_model(conf, models, names, graph)
    quality = quality_record(model, models, names, graph, matching, angle)
    return model, msgspec.structs.replace(quality, thorough=thorough), database


def extract(conf: ReconstructionConfig, images_dir: Path, names: list[str], database: Path) -> None:
    options = pycolmap.FeatureExtractionOptions()
    options.max_image_size = conf.max_image_size if conf.max_image_size > 0 else -1
    options.sift.max_num_features = conf.sift_max_features
    options.sift.first_octave = conf.sift_first_octave
    options.sift.peak_threshold = conf.sift_peak_threshold
    reader = pycolmap.ImageReaderOptions()
    reader.camera_model = conf.camera_model
    pycolmap.extract_features(
        database,
        images_dir,
        image_names=names,
        camera_mode=pycolmap.CameraMode.SINGLE,
        reader_options=reader,
        extraction_options=options,
        device=pycolmap.Device.cpu,
    )


def match(
    conf: ReconstructionConfig, names: list[str], images_dir: Path, database: Path, work: Path, *, video: bool
) -> str:
    options = pycolmap.FeatureMatchingOptions()
    options.guided_matching = conf.guided_matching
    if not video:
        pycolmap.match_exhaustive(database, matching_options=options, device=pycolmap.Device.cpu)
        return "exhaustive"
    # Frames of one video: neighbours in time, plus the most similar earlier frames so that an
    # orbit that comes back to its start closes the loop (COLMAP's own loop detection needs a
    # vocabulary tree file, which an offline clinic does not have).
    pairs = video_pairs(images_dir, names, conf.video_overlap, conf.video_loop_candidates)
    pairs_file = work / "pairs.txt"
    pairs_file.write_text("".join(f"{a} {b}\n" for a, b in pairs))
    pycolmap.match_image_pairs(
        database,
        matching_options=options,
        pairing_options=pycolmap.ImportedPairingOptions(match_list_path=str(pairs_file)),
        device=pycolmap.Device.cpu,
    )
    return "sequential+loop"


def video_pairs(images_dir: Path, names: list[str], overlap: int, loop_candidates: int) -> list[tuple[str, str]]:
    """Pairs of frames to match: each frame with its next `overlap` frames and its most similar earlier ones."""
    ordered = sorted(names)
    pairs = {
        (ordered[i], ordered[j]) for i in range(len(ordered)) for j in range(i + 1, min(i + 1 + overlap, len(ordered)))
    }
    if loop_candidates:
        thumbs = np.stack([_thumbnail(images_dir / name) for name in ordered])
        similarity = thumbs @ thumbs.T
        for i in range(len(ordered)):
            earlier = [j for j in range(i - overlap) if j >= 0]
            for j in sorted(earlier, key=lambda j: -similarity[i, j])[:loop_candidates]:
                pairs.add((ordered[j], ordered[i]))
    return sorted(pairs)


def _thumbnail(path: Path) -> np.ndarray:
    image = cv2.imread(str(path), cv2.IMREAD_REDUCED_GRAYSCALE_8 | cv2.IMREAD_IGNORE_ORIENTATION)
    if image is None:
        raise CaptureInsufficient(f"{path.name} could not be decoded", code=FailureCode.no_pictures)
    small = cv2.resize(image, (32, 24), interpolation=cv2.INTER_AREA).astype(np.float32).ravel()
    small -= small.mean()
    return small / (np.linalg.norm(small) + 1e-9)


def incremental_map(
    conf: ReconstructionConfig, images_dir: Path, names: list[str], database: Path, out: Path
) -> list[pycolmap.Reconstruction]:
    fresh_dir(out)
    options = pycolmap.IncrementalPipelineOptions()
    options.min_model_size = 3
    options.image_names = names
    options.mapper.abs_pose_min_num_inliers = conf.min_pose_inliers
    options.mapper.abs_pose_min_inlier_ratio = conf.min_pose_inlier_ratio
    options.mapper.init_min_tri_angle = 8.0  # close-range captures: 16 degrees refuses good initial pairs
    options.random_seed = 1
    models = pycolmap.incremental_mapping(database, images_dir, out, options=options)
    return sorted(models.values(), key=lambda m: -m.num_reg_images())
