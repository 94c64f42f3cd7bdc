"""The burn analysis: reconstruction, then segmentation, mapping and metrics, in one analysis folder.

    OUT/ ... the reconstruction's artifacts (see processing/reconstruction/pipeline.py)
    OUT/segmentation/segmentation.json, masks/, probability/, overlays/
    OUT/surface/burn_surface.npz, burn_surface.glb   the burn painted on the mesh
    OUT/metrics/metrics.json
    OUT/analysis.json                                the result a clinician reads

Stages resume as the reconstruction's do: a stage whose artifact exists and whose inputs (settings,
model, the person's masks, the reconstruction under it) are unchanged is skipped.
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Callable
from pathlib import Path

import msgspec
import numpy as np

from processing.analysis import confidence, measure, outline_evidence, segment_views, surface_map
from processing.clinical.bsa import mosteller
from processing.reconstruction import pipeline as reconstruction
from processing.reconstruction.dense import DenseInfo
from processing.segmentation.infer import SHIPPED_MODEL
from processing.stages import Stages, read_json, write_json
from schemas.analysis import AnalysisResult, AnalysisStatus, ScaleSummary, SegmentationRecord
from schemas.config import Config
from schemas.errors import CaptureInsufficient, InvalidInput
from schemas.reconstruction import FailureCode, Outcome, ReconstructionReport, RulerPoints
from schemas.segmentation import MaskSource

log = logging.getLogger(__name__)

RESULT = "analysis.json"
FINGERPRINTS = "analysis_fingerprints.json"


class Patient(msgspec.Struct, frozen=True, kw_only=True):
    """What the analysis may know about the patient (all optional)."""

    hours_since_injury: float | None = None
    height_cm: float | None = None
    weight_kg: float | None = None


def _digest(*parts: object) -> str:
    return hashlib.sha256(json.dumps(parts, sort_keys=True, default=str).encode()).hexdigest()


def _files_digest(folder: Path | None) -> str:
    if folder is None or not folder.is_dir():
        return ""
    return _digest(
        [(f.name, hashlib.sha256(f.read_bytes()).hexdigest()) for f in sorted(folder.iterdir()) if f.is_file()]
    )


def fingerprints(config: Config, out: Path, masks: Path | None) -> dict[str, str]:
    model = Path(config.analysis.model) if config.analysis.model else SHIPPED_MODEL
    under = json.loads((out / reconstruction.FINGERPRINTS).read_text()).get("mesh", "")
    settings = msgspec.to_builtins(msgspec.structs.replace(config.analysis, threads=1))  # threads change nothing
    version = reconstruction.software_versions().get("burnedge", "")
    segment = _digest(
        under,
        settings,
        version,
        _files_digest(masks),
        hashlib.sha256(model.read_bytes()).hexdigest() if model.is_file() else "",
    )
    surface = _digest(segment)
    return {"segment": segment, "surface": surface, "metrics": _digest(surface)}


def check_request(config: Config, out: Path, masks: Path | None, patient: Patient) -> None:
    """Refuses, before anything runs or is removed, what cannot give a result."""
    if patient.hours_since_injury is not None and patient.hours_since_injury < 0:
        raise InvalidInput(f"hours since injury must be 0 or more, got {patient.hours_since_injury:g}")
    if (patient.height_cm is None) != (patient.weight_kg is None):
        raise InvalidInput("give both the patient's height and weight for %TBSA, or neither")
    if patient.height_cm is not None:
        mosteller(patient.weight_kg, patient.height_cm)  # raises with the plausible ranges
    if masks is not None:
        if not masks.is_dir():
            raise InvalidInput(f"--masks {masks} is not a folder")
        m, o = masks.resolve(), out.resolve()
        if m == o or o in m.parents or m in o.parents:
            raise InvalidInput(
                f"--masks {masks} lies inside the analysis folder {out} (or holds it): the analysis "
                "rewrites its own masks there; copy the corrected masks to a folder of their own"
            )
    if config.analysis.model and not Path(config.analysis.model).is_file():
        raise InvalidInput(f"[analysis] model {config.analysis.model} is not a file")


def run(
    config: Config,
    source: Path,
    out: Path,
    *,
    masks: Path | None = None,
    ruler: RulerPoints | None = None,
    patient: Patient | None = None,
    gate: bool = True,
    progress: Callable[[str], None] | None = None,
) -> AnalysisResult:
    """Run (or resume) the whole analysis; the result is also written to OUT/analysis.json.

    `progress(stage)` is called as each stage of the reconstruction and of the analysis starts.
    """
    patient = patient or Patient()
    check_request(config, out, masks, patient)
    (out / RESULT).unlink(missing_ok=True)
    report = reconstruction.run(config, source, out, ruler, gate=gate, progress=progress)
    timings = {t.stage: t.seconds for t in report.timings}
    reused = [t.stage for t in report.timings if t.resumed]

    def failed(reason: str, code: FailureCode) -> AnalysisResult:
        return _write(
            out,
            AnalysisResult(
                status=AnalysisStatus.failed,
                reason=reason,
                failure=code,
                timings_s=timings,
                reused_stages=reused,
                hours_since_injury=patient.hours_since_injury,
                software=report.software,
            ),
        )

    if report.outcome is Outcome.failed:
        return failed(report.reason, report.failure)
    p = {
        "segment": out / "segmentation" / segment_views.RECORD,
        "surface": out / "surface" / surface_map.ARRAYS,
        "metrics": out / "metrics" / measure.RESULT,
    }
    stages = Stages(out / FINGERPRINTS, p, fingerprints(config, out, masks), progress)

    def stage(name: str, work: Callable[[], object]) -> None:
        stages.run(name, work)
        timings[name] = stages.timings[-1].seconds
        if stages.timings[-1].resumed:
            reused.append(name)

    paths = reconstruction.paths(out)
    mm_per_unit = report.scale.mm_per_unit if report.scale else None
    try:
        dense = read_json(paths["dense_info"], DenseInfo)
        views = surface_map.output_views(paths["sfm_model"], paths["scale"])
        aim = np.array(dense.roi_centres[0])  # the point the cameras aim at: the burn
        boxes = surface_map.crop_boxes(views, aim, config.analysis.crop_radius_mm * dense.units_per_mm)
        stage(
            "segment",
            lambda: segment_views.run(
                config.analysis, paths["images"], [v.name for v in views], p["segment"].parent, masks, boxes
            ),
        )
        stage(
            "surface",
            lambda: surface_map.run(
                config.analysis,
                views,
                paths["mesh_ply"],
                p["segment"].parent,
                p["surface"].parent,
                aim,
                dense.roi_radii[0],
            ),
        )
        stage(
            "metrics",
            lambda: measure.run(
                config.analysis, p["surface"], mm_per_unit, dense.units_per_mm, views, p["metrics"].parent
            ),
        )
    except CaptureInsufficient as exc:
        return failed(exc.detail, FailureCode(exc.code))
    except InvalidInput as exc:
        return failed(exc.detail, FailureCode.bad_input)
    except Exception as exc:
        failed(
            f"the analysis stopped on an unexpected error ({exc}); the pictures and the reconstruction are kept, "
            "please report this to your IT contact",
            FailureCode.internal_error,
        )
        raise
    return _write(out, msgspec.structs.replace(_result(config, report, patient, timings, p), reused_stages=reused))


def _result(
    config: Config, report: ReconstructionReport, patient: Patient, timings: dict[str, float], p: dict[str, Path]
) -> AnalysisResult:
    measured = read_json(p["metrics"], measure.Measurement)
    segmentation = read_json(p["segment"], SegmentationRecord)
    masks = segmentation.views
    scale = report.scale
    scaled = bool(scale and scale.mm_per_unit)
    unc = scale.relative_uncertainty * 100 if scaled and scale.relative_uncertainty is not None else None
    cut_views = [m.image for m in masks if m.burn_at_crop_edge]
    conf = confidence.score(
        views_used=report.sfm.images_registered,
        views_seeing_burn=measured.views_seeing_burn,
        inlier_ratio=report.sfm.mean_inlier_ratio,
        reprojection_px=report.sfm.median_reprojection_error_px,
        seen3=measured.burn_seen_by_3_fraction,
        scale_uncertainty_percent=unc if scaled else None,
        clinician_masks=sum(m.source is not MaskSource.model for m in masks),
        cut_off=measured.open_edges > 0 or measured.burn_at_surface_edge,
        outline_cut_views=len(cut_views),
        min_views=config.analysis.min_views_for_confidence,
        outline=outline_evidence.gather(segmentation, measured.view_agreement),
        area_cm2=measured.metrics.area_cm2,
    )
    notes = []
    if segmentation.unmatched_masks:
        notes.append(f"masks not used, named after no placed picture: {', '.join(segmentation.unmatched_masks)}")
    if cut_views:
        notes.append(
            f"the model's burn reaches the edge of the area it looked at in {', '.join(cut_views)}: "
            "check the outlines on those photos; if the burn is larger, draw its outline on the photos "
            "(a person's outline replaces the model's) and analyse again"
        )
    if measured.relief_note:
        notes.append(measured.relief_note)
    metrics = measured.metrics
    if metrics.area_cm2 is not None and patient.height_cm and patient.weight_kg:
        bsa_cm2 = mosteller(patient.weight_kg, patient.height_cm).bsa_m2 * 1e4
        metrics = msgspec.structs.replace(metrics, tbsa_percent=round(100 * metrics.area_cm2 / bsa_cm2, 3))
    hours = patient.hours_since_injury
    artifacts = {
        **report.artifacts,
        "analysis_masks": "segmentation/masks",
        "overlays": "segmentation/overlays",
        "painted_mesh": f"surface/{surface_map.GLB}",
        "metrics": f"metrics/{measure.RESULT}",
    }
    return AnalysisResult(
        status=AnalysisStatus.ok if scaled else AnalysisStatus.unscaled,
        reason=None
        if scaled
        else f"no scale ({scale.note if scale else 'none found'}): sizes are not reported "
        "in mm or cm; put the printed marker beside the burn, or mark ruler points",
        metrics=metrics,
        confidence=conf,
        scale=ScaleSummary(
            method=scale.source.value if scale else "none",
            mm_per_unit=scale.mm_per_unit if scale else None,
            uncertainty_percent=round(unc, 3) if unc is not None else None,
        ),
        timings_s=timings,
        hours_since_injury=hours,
        provisional=None if hours is None else hours < config.analysis.provisional_hours,
        notes=notes,
        views=masks,
        fusion_rule=config.analysis.fusion_rule,
        reference=measured.reference,
        artifacts=artifacts,
        software=report.software,
    )


def _write(out: Path, result: AnalysisResult) -> AnalysisResult:
    write_json(out / RESULT, result)
    return result
