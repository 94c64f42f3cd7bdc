"""An analysis's measurements as a Comprehensive 3D SR following TID 1500 (Measurement Report), made with
highdicom's TID 1500 classes, which check the template as they build it.

Area, perimeter and volume use SNOMED CT concepts with UCUM units. Surface relief is geometry, not the clinical
burn depth: it has burnedge's own code (99BURNEDGE), never SNOMED CT "Depth" nor any burn-depth concept. The scale's
source, the confidence and whether the figures are provisional are qualitative evaluations of the same group, and
every measurement references the photos it was measured from.
"""

from __future__ import annotations

from highdicom.coding_schemes import CodingSchemeIdentificationItem
from highdicom.sr import (
    AlgorithmIdentification,
    Comprehensive3DSR,
    DeviceObserverIdentifyingAttributes,
    Measurement,
    MeasurementReport,
    MeasurementsAndQualitativeEvaluations,
    ObservationContext,
    ObserverContext,
    QualitativeEvaluation,
    SourceImageForMeasurement,
    SourceImageForMeasurementGroup,
    TrackingIdentifier,
)
from pydicom.dataset import Dataset
from pydicom.sr.codedict import codes
from pydicom.sr.coding import Code

from processing.dicom import anatomy, common, identity
from processing.dicom.inputs import Analysis, StudyInput
from schemas.analysis import AnalysisStatus

LOCAL = "99BURNEDGE"
"""burnedge's private coding scheme (DICOM reserves designators beginning "99" for private ones), for what no
checked code says. Each code value is at most 16 characters, so it stays a CodeValue (SH), never a LongCodeValue."""

RELIEF_MAX = Code("relief-max", LOCAL, "Surface relief, deepest (not burn depth)")
RELIEF_MEAN = Code("relief-mean", LOCAL, "Surface relief, mean (not burn depth)")
RAISED_MAX = Code("raised-max", LOCAL, "Surface raised above fitted skin, highest")
BODY_SHARE = Code("tbsa-share", LOCAL, "Share of body surface area (Mosteller)")
CONFIDENCE_SCORE = Code("confidence", LOCAL, "Measurement confidence score")
CONFIDENCE_LEVEL = Code("confidence-level", LOCAL, "Measurement confidence level")
PROVISIONAL = Code("provisional", LOCAL, "Provisional: under 72 h after the injury")
MARKER_SHEET = Code("marker-sheet", LOCAL, "Printed fiducial marker sheet")
NO_SCALE = Code("no-scale", LOCAL, "No metric scale found")
SHARED = (
    "TimezoneOffsetFromUTC",
    "InstanceCreationDate",
    "InstanceCreationTime",
    "IssuerOfPatientID",
    "StudyDescription",
)
"""Shared-module attributes highdicom does not copy from the evidence (it copies the patient and the study's
identity from the photos)."""
BURN = Code("125666000", "SCT", "Burn")
"""As the FHIR export codes a wound (docs/fhir.md); not in pydicom's PS3.16 dictionary."""

LEVELS = {"high": codes.SCT.High, "moderate": codes.SCT.Medium, "low": codes.SCT.Low}
SCALE_SOURCE = {"marker": MARKER_SHEET, "ruler": codes.SCT.MeasuringRuler}
UNIT_CM2 = codes.UCUM.SquareCentimeter
UNIT_CM = codes.UCUM.Centimeter
UNIT_MM = codes.UCUM.Millimeter
UNIT_CM3 = codes.UCUM.CubicCentimeter
UNIT_PERCENT = codes.UCUM.Percent
UNIT_NONE = codes.UCUM.NoUnits


def instance_uid(job_id: str) -> str:
    return identity.uid("burn_analysis", job_id, "measurement-report")


def _evaluations(analysis: Analysis) -> list[QualitativeEvaluation]:
    result = analysis.record.result
    scale = result.scale.method if result.scale else "none"
    out = [QualitativeEvaluation(codes.DCM.CalibrationObject, SCALE_SOURCE.get(scale, NO_SCALE))]
    provisional = {True: codes.SCT.Yes, False: codes.SCT.No}.get(result.provisional, codes.SCT.Unknown)
    out.append(QualitativeEvaluation(PROVISIONAL, provisional))
    if result.confidence is not None and result.confidence.level in LEVELS:
        out.append(QualitativeEvaluation(CONFIDENCE_LEVEL, LEVELS[result.confidence.level]))
    return out


def _measurements(analysis: Analysis, images: list[SourceImageForMeasurement], sites) -> list[Measurement]:
    result = analysis.record.result
    m = result.metrics
    figures: list[tuple[Code, float | None, Code]] = [
        (codes.SCT.Area, m.area_cm2, UNIT_CM2),
        (codes.SCT.Perimeter, m.perimeter_cm, UNIT_CM),
        (RELIEF_MAX, m.relief_max_mm, UNIT_MM),
        (RELIEF_MEAN, m.relief_mean_mm, UNIT_MM),
        (RAISED_MAX, m.raised_max_mm, UNIT_MM),
        (codes.SCT.Volume, m.volume_cm3, UNIT_CM3),
        (BODY_SHARE, m.tbsa_percent, UNIT_PERCENT),
    ]
    if result.scale is not None and result.scale.uncertainty_percent is not None:
        figures.append((codes.DCM.CalibrationUncertainty, result.scale.uncertainty_percent, UNIT_PERCENT))
    if result.confidence is not None:
        figures.append((CONFIDENCE_SCORE, result.confidence.score, UNIT_NONE))
    return [
        Measurement(
            name=name,
            value=float(value),
            unit=unit,
            method=codes.DCM.ShapeFromMotion,
            finding_sites=sites or None,
            referenced_images=images or None,
        )
        for name, value, unit in figures
        if value is not None
    ]


def report(study: StudyInput, analysis: Analysis, photos: list[Dataset], number: int) -> Dataset:
    """The TID 1500 report of one analysis; `photos` are the VL Photographic Images it was measured from."""
    record = analysis.record
    wound = study.wound(record.wound_id)
    sites = anatomy.finding_sites(wound)
    group_images = [SourceImageForMeasurementGroup(p.SOPClassUID, p.SOPInstanceUID) for p in photos]
    images = [SourceImageForMeasurement(p.SOPClassUID, p.SOPInstanceUID) for p in photos]
    group = MeasurementsAndQualitativeEvaluations(
        tracking_identifier=TrackingIdentifier(
            uid=identity.uid("burn_analysis", record.job_id, "tracking"),
            identifier=(wound.label if wound else "burn")[:64],
        ),
        finding_type=BURN,
        method=codes.DCM.ShapeFromMotion,
        algorithm_id=AlgorithmIdentification(name="burnedge 3D burn analysis", version=study.software_version),
        finding_sites=sites or None,
        measurements=_measurements(analysis, images, sites) or None,
        qualitative_evaluations=_evaluations(analysis),
        source_images=group_images or None,
    )
    device = DeviceObserverIdentifyingAttributes(
        uid=identity.uid("software", "burnedge", "device-observer"), name="burnedge", manufacturer_name="burnedge"
    )
    context = ObservationContext(observer_device_context=ObserverContext(codes.DCM.Device, device))
    content = MeasurementReport(
        observation_context=context,
        procedure_reported=codes.SCT.PhotographyOfPatient,
        imaging_measurements=[group],
        referenced_images=photos or None,
    )
    completed = identity.parse_iso(record.completed_at) or study.made_at
    shared = common.dataset(study, common.MEASUREMENTS, "", "", number, completed)
    sr = Comprehensive3DSR(
        evidence=photos,
        content=content[0],
        series_instance_uid=shared.SeriesInstanceUID,
        series_number=shared.SeriesNumber,
        sop_instance_uid=instance_uid(record.job_id),
        instance_number=number,
        manufacturer=common.MANUFACTURER,
        is_complete=True,
        is_final=record.result.provisional is False and record.result.status is AnalysisStatus.ok,
        institution_name=study.institution[:64] or None,
        series_description=common.MEASUREMENTS.description,
        software_versions=study.software_version or "unknown",
        coding_schemes=[
            CodingSchemeIdentificationItem(
                designator=LOCAL, name="burnedge local codes", responsible_organization="burnedge"
            )
        ],
    )
    for keyword in SHARED:
        if keyword in shared:
            setattr(sr, keyword, shared.data_element(keyword).value)
    sr.ContentDate, sr.ContentTime = shared.ContentDate, shared.ContentTime
    sr.SpecificCharacterSet = "ISO_IR 192"
    return sr
