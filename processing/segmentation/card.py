"""What a segmentation model file says about itself: version, passes, fairness, held-out scores."""

from __future__ import annotations

from pathlib import Path

import msgspec

from processing.segmentation.infer import BurnSegmenter, fairness_of
from schemas.segmentation import ModelInfo, TrainingReport

REPORT = "training_report.json"


def model_info(model: str | Path = "") -> ModelInfo:
    """The model's card from its ONNX metadata and, when it lies beside the model, its training report."""
    segmenter = BurnSegmenter(model)
    meta = segmenter.metadata
    report = None
    beside = segmenter.path.parent / REPORT
    if beside.is_file():
        try:
            report = msgspec.json.decode(beside.read_bytes(), type=TrainingReport)
        except msgspec.ValidationError:
            report = None  # the report of another model or version: its figures are not this model's
        if report is not None and report.model_sha256 != segmenter.sha256:
            report = None
    return ModelInfo(
        version=meta.get("version", ""),
        sha256=segmenter.sha256,
        file=str(segmenter.path),
        license=meta.get("license", ""),
        card=meta.get("card", ""),
        passes=segmenter.settings,
        fairness=fairness_of(meta),
        real_validation=report.real_validation if report else None,
        synthetic_validation=report.synthetic_validation if report else None,
        architecture=meta.get("architecture", ""),
    )
