"""A study's inputs built in memory for the DICOM writer's unit tests: a patient, an encounter in a +01:00 zone, a
wound of the left forearm, two camera JPEGs and a PNG, one finished scaled analysis with its painted surface (a box, half of it burnt), and
a small PDF."""

from __future__ import annotations

import datetime as dt
import io

import numpy as np
import trimesh
from PIL import Image

from processing.analysis import paint
from processing.dicom.inputs import Analysis, Photo, StudyInput
from schemas.analysis import AnalysisResult, AnalysisStatus, BurnMetrics, ConfidenceRecord, ScaleSummary
from schemas.burn_chart import LundBrowderRegion
from schemas.ids import uuid7
from schemas.jobs import BurnAnalysis
from schemas.patient import Encounter, EncounterMode, Patient, Sex
from schemas.wound import Wound, WoundSide

ZONE = dt.timezone(dt.timedelta(hours=1))
ARRIVAL = dt.datetime(2026, 11, 13, 5, 30, tzinfo=ZONE)
PDF = b"%PDF-1.4\n1 0 obj<<>>endobj\ntrailer<<>>\n%%EOF\n"


def jpeg(seed: int, size=(320, 240), **save) -> bytes:
    rng = np.random.default_rng(seed)
    pixels = rng.integers(0, 255, (size[1], size[0], 3), dtype=np.uint8)
    out = io.BytesIO()
    Image.fromarray(pixels).save(out, format="JPEG", quality=90, **save)
    return out.getvalue()


def png(seed: int, size=(64, 48)) -> bytes:
    rng = np.random.default_rng(seed)
    out = io.BytesIO()
    Image.fromarray(rng.integers(0, 255, (size[1], size[0], 3), dtype=np.uint8)).save(out, format="PNG")
    return out.getvalue()


SKIN = np.array([0.82, 0.62, 0.52])


def painted_box(extents=(40, 30, 5)) -> bytes:
    """A box (mm) painted as burn_surface.glb paints a burn (processing/analysis/paint.py): q = 0.9 where x > 0, the
    skin's colour elsewhere."""
    box = trimesh.creation.box(extents=extents).subdivide().subdivide()
    q = np.where(box.vertices[:, 0] > 0, 0.9, np.nan)
    alpha = paint.alpha(q)[:, None]
    colours = SKIN * (1 - alpha) + paint.PAINT * alpha
    tri = trimesh.Trimesh(box.vertices, box.faces, process=False, vertex_colors=(colours * 255).astype(np.uint8))
    return trimesh.exchange.gltf.export_glb(trimesh.Scene(tri))


def analysis_record(encounter_id: str, assets: list[str], wound_id: str | None, **metrics) -> BurnAnalysis:
    figures = {"area_cm2": 18.4, "perimeter_cm": 17.2, "relief_max_mm": 1.6, "volume_cm3": 0.42, "burn_loops": 1}
    result = AnalysisResult(
        status=AnalysisStatus.ok,
        metrics=BurnMetrics(**(figures | metrics)),
        confidence=ConfidenceRecord(score=0.86, level="high", views_used=8, views_seeing_burn=8),
        scale=ScaleSummary(method="marker", mm_per_unit=1.0, uncertainty_percent=1.5),
        hours_since_injury=3.0,
        provisional=True,
    )
    return BurnAnalysis(
        encounter_id=encounter_id,
        job_id=uuid7(),
        assets=assets,
        requested_by="clin",
        requested_at="2026-11-13T05:40:00+01:00",
        completed_at="2026-11-13T05:49:00+01:00",
        result=result,
        wound_id=wound_id,
    )


def study_input(**patient) -> StudyInput:
    person = Patient(
        id=uuid7(),
        **(
            {"given_name": "Amara", "family_name": "Okafor", "medical_record_number": "MRN-4471", "sex": Sex.female}
            | patient
        ),
    )
    encounter = Encounter(
        id=uuid7(),
        patient_id=person.id,
        mode=EncounterMode.emergency,
        time_of_arrival=ARRIVAL,
        time_of_injury=ARRIVAL - dt.timedelta(hours=2),
        clinician="Dr. Test",
    )
    wound = Wound(
        id=uuid7(),
        patient_id=person.id,
        regions=[LundBrowderRegion.lower_arm_left_anterior],
        label="left forearm",
        side=WoundSide.left,
    )
    taken = ARRIVAL + dt.timedelta(minutes=5)
    photos = [
        Photo(uuid7(), jpeg(1), "image/jpeg", "a.jpg", taken, "Acme", "Phone 1", wound.id),
        Photo(uuid7(), jpeg(2, progressive=True), "image/jpeg", "b.jpg", None, wound_id=wound.id),
        Photo(uuid7(), png(3), "image/png", "c.png"),
    ]
    record = analysis_record(encounter.id, [p.asset_id for p in photos], wound.id)
    glb = painted_box()
    return StudyInput(
        patient=person,
        encounter=encounter,
        wounds=[wound],
        photos=photos,
        analyses=[Analysis(record, glb)],
        report_pdf=PDF,
        made_at=ARRIVAL + dt.timedelta(hours=1),
        software_version="0.1.0",
        institution="Test field clinic",
    )
