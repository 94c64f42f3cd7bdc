"""The DICOM writer (processing/dicom) without a PACS: every object read back with pydicom with the attributes its
IOD requires, the SR read back through highdicom's TID 1500 classes, stable UIDs, the PatientID rule, times with
their zone, and surface relief never coded as depth. Sent to a real Orthanc in tests/test_dicom_pacs.py."""

from __future__ import annotations

import io

import msgspec
import pytest
from highdicom.sr import Comprehensive3DSR, MeasurementReport
from pydicom import dcmread
from pydicom.uid import (
    Comprehensive3DSRStorage,
    EncapsulatedPDFStorage,
    EncapsulatedSTLStorage,
    ExplicitVRLittleEndian,
    JPEGBaseline8Bit,
    SurfaceScanMeshStorage,
    VLPhotographicImageStorage,
)

from processing.dicom import identity
from processing.dicom.measurements import RELIEF_MAX
from processing.dicom.photo import baseline_frame
from processing.dicom.study import build
from schemas.analysis import AnalysisStatus, ScaleSummary
from schemas.dicom import PatientIdRule
from tests.dicom_inputs import PDF, jpeg, study_input

SHARED = ("PatientName", "PatientID", "PatientBirthDate", "PatientSex", "StudyInstanceUID", "StudyDate", "StudyTime")
SHARED += ("ReferringPhysicianName", "StudyID", "AccessionNumber", "Modality", "SeriesInstanceUID", "SeriesNumber")
SHARED += ("Manufacturer", "InstanceNumber", "SOPClassUID", "SOPInstanceUID", "TimezoneOffsetFromUTC")
REQUIRED = {
    VLPhotographicImageStorage: (
        *("ImageType", "Rows", "Columns", "SamplesPerPixel", "PhotometricInterpretation", "BitsAllocated"),
        *("BitsStored", "HighBit", "PixelRepresentation", "PixelData", "AcquisitionContextSequence"),
        *("ContentDate", "ContentTime", "LossyImageCompression", "PatientOrientation"),
    ),
    Comprehensive3DSRStorage: (
        *("ValueType", "ConceptNameCodeSequence", "ContentSequence", "CompletionFlag", "VerificationFlag"),
        *("ContentTemplateSequence", "CurrentRequestedProcedureEvidenceSequence", "ContentDate", "ContentTime"),
    ),
    EncapsulatedSTLStorage: (
        *("FrameOfReferenceUID", "MeasurementUnitsCodeSequence", "EncapsulatedDocument", "DocumentTitle"),
        *("MIMETypeOfEncapsulatedDocument", "EncapsulatedDocumentLength", "ManufacturerModelName"),
        *("DeviceSerialNumber", "SoftwareVersions", "BurnedInAnnotation", "ConceptNameCodeSequence"),
    ),
    EncapsulatedPDFStorage: (
        *("ConversionType", "BurnedInAnnotation", "DocumentTitle", "ConceptNameCodeSequence"),
        *("MIMETypeOfEncapsulatedDocument", "EncapsulatedDocument", "ContentDate", "ContentTime"),
    ),
    SurfaceScanMeshStorage: (
        *("FrameOfReferenceUID", "PositionReferenceIndicator", "ManufacturerModelName", "DeviceSerialNumber"),
        *("SoftwareVersions", "AcquisitionDateTime", "SurfaceScanAcquisitionTypeCodeSequence"),
        *("SurfaceScanModeCodeSequence", "ShotDurationTime", "NumberOfSurfaces", "SurfaceSequence"),
    ),
}


def _read(study) -> list:
    return [dcmread(io.BytesIO(data)) for _name, data in study.files()]


def _of(datasets, sop_class) -> list:
    return [ds for ds in datasets if ds.SOPClassUID == sop_class]


def test_every_object_reads_back_with_the_attributes_its_iod_requires():
    inputs = study_input()
    datasets = _read(build(inputs))
    assert sorted(str(ds.SOPClassUID) for ds in datasets) == sorted(
        [VLPhotographicImageStorage] * 3
        + [Comprehensive3DSRStorage, EncapsulatedSTLStorage, EncapsulatedPDFStorage, SurfaceScanMeshStorage]
    )
    for ds in datasets:
        assert ds.preamble is not None and ds.file_meta.MediaStorageSOPInstanceUID == ds.SOPInstanceUID
        missing = [k for k in (*SHARED, *REQUIRED[ds.SOPClassUID]) if k not in ds]
        assert missing == [], (ds.SOPClassUID.name, missing)
        assert ds.PatientID == "MRN-4471" and str(ds.PatientName) == "Okafor^Amara" and ds.PatientSex == "F"
        assert ds.StudyInstanceUID == datasets[0].StudyInstanceUID
        assert ds.TimezoneOffsetFromUTC == "+0100" and ds.StudyDate == "20261113" and ds.StudyTime == "053000"
    assert len({ds.SeriesInstanceUID for ds in datasets}) == 5
    assert len({ds.SOPInstanceUID for ds in datasets}) == len(datasets)


def test_a_baseline_jpeg_is_kept_as_taken_and_other_pictures_are_decoded_once():
    inputs = study_input()
    first, progressive, png = _of(_read(build(inputs)), VLPhotographicImageStorage)
    assert first.file_meta.TransferSyntaxUID == JPEGBaseline8Bit
    assert inputs.photos[0].data in bytes(first.PixelData)  # the camera's bytes, encapsulated
    assert first.PhotometricInterpretation in ("YBR_FULL_422", "YBR_FULL") and first.LossyImageCompression == "01"
    assert first.pixel_array.shape == (240, 320, 3)  # pydicom decodes what it was given
    assert first.AcquisitionDateTime == "20261113053500+0100"  # the camera clock, with its zone
    assert first.ManufacturerModelName == "Phone 1"
    assert first.ImageLaterality == "L" and first.AnatomicRegionSequence[0].CodeValue == "14975008"  # forearm
    assert baseline_frame(inputs.photos[1].data) is None  # progressive: not Process 1
    assert progressive.file_meta.TransferSyntaxUID == ExplicitVRLittleEndian
    assert progressive.PhotometricInterpretation == "RGB" and progressive.LossyImageCompressionMethod == "ISO_10918_1"
    assert progressive.pixel_array.shape == (240, 320, 3) and "AcquisitionDateTime" not in progressive
    assert png.LossyImageCompression == "00" and png.pixel_array.shape == (48, 64, 3)
    assert "AnatomicRegionSequence" not in png  # no wound said: no region invented
    assert baseline_frame(b"not a jpeg") is None and baseline_frame(jpeg(4)) is not None


def test_the_sr_is_a_tid_1500_report_highdicom_reads_back_with_units_and_its_source_photos():
    inputs = study_input()
    datasets = _read(build(inputs))
    (sr,) = _of(datasets, Comprehensive3DSRStorage)
    photo_uids = {str(ds.SOPInstanceUID) for ds in _of(datasets, VLPhotographicImageStorage)}
    assert sr.ContentTemplateSequence[0].TemplateIdentifier == "1500"
    parsed = Comprehensive3DSR.from_dataset(sr)
    report = MeasurementReport.from_sequence([parsed])
    (group,) = report.get_image_measurement_groups()
    figures = {m.name.value: (m.value, m.unit.value) for m in group.get_measurements()}
    metrics = inputs.analyses[0].record.result.metrics
    assert figures["42798000"] == (metrics.area_cm2, "cm2")  # SNOMED CT Area
    assert figures["131191004"] == (metrics.perimeter_cm, "cm")  # Perimeter
    assert figures["118565006"] == (metrics.volume_cm3, "cm3")  # Volume
    assert figures[RELIEF_MAX.value] == (metrics.relief_max_mm, "mm")
    assert figures["confidence"] == (0.86, "1") and figures["113763"] == (1.5, "%")  # calibration uncertainty
    assert "131197000" not in figures  # SNOMED CT Depth: surface relief is never coded as depth
    assert not any("depth" in m.name.meaning.lower().replace("not burn depth", "") for m in group.get_measurements())
    evaluations = {e.name.value: e.value.value for e in group.get_qualitative_evaluations()}
    assert evaluations["122421"] == "marker-sheet"  # DCM Calibration Object: the scale's source
    assert evaluations["provisional"] == "373066001" and evaluations["confidence-level"] == "75540009"  # Yes, High
    (site,) = group.finding_sites
    assert site.value.value == "14975008" and site.laterality.value == "7771000"  # forearm, left
    referenced = {str(r.referenced_sop_instance_uid) for m in group.get_measurements() for r in m.referenced_images}
    assert referenced == photo_uids
    evidence = sr.CurrentRequestedProcedureEvidenceSequence[0].ReferencedSeriesSequence[0].ReferencedSOPSequence
    assert {str(e.ReferencedSOPInstanceUID) for e in evidence} == photo_uids
    assert sr.PreliminaryFlag == "PRELIMINARY"  # provisional figures
    assert sr.CodingSchemeIdentificationSequence[0].CodingSchemeDesignator == "99BURNEDGE"


def test_the_surface_is_an_encapsulated_stl_in_mm_and_the_report_an_encapsulated_pdf():
    datasets = _read(build(study_input()))
    (stl,) = _of(datasets, EncapsulatedSTLStorage)
    data = bytes(stl.EncapsulatedDocument)[: stl.EncapsulatedDocumentLength]
    import trimesh

    mesh = trimesh.load(io.BytesIO(data), file_type="stl")
    assert sorted(round(float(x)) for x in mesh.extents) == [5, 30, 40]  # the box, in mm
    assert stl.MeasurementUnitsCodeSequence[0].CodeValue == "mm" and stl.MIMETypeOfEncapsulatedDocument == "model/stl"
    assert len(stl.SourceInstanceSequence) == 3
    (pdf,) = _of(datasets, EncapsulatedPDFStorage)
    assert bytes(pdf.EncapsulatedDocument)[: pdf.EncapsulatedDocumentLength] == PDF


def test_uids_are_stable_so_a_second_export_replaces_and_never_doubles():
    inputs = study_input()
    first = [(ds.SOPInstanceUID, ds.SeriesInstanceUID, ds.StudyInstanceUID) for ds in build(inputs).instances]
    again = [(ds.SOPInstanceUID, ds.SeriesInstanceUID, ds.StudyInstanceUID) for ds in build(inputs).instances]
    assert first == again and all(uid.startswith("2.25.") and len(uid) <= 64 for uid, *_ in first)
    other = [ds.SOPInstanceUID for ds in build(study_input()).instances]  # other records: other UIDs
    assert not {uid for uid, *_ in first} & set(other)
    assert identity.uid("asset", "a", "vl-photographic-image") != identity.uid("asset", "b", "vl-photographic-image")


def test_a_patient_without_a_record_number_gets_one_by_the_rule_never_an_empty_patient_id():
    unknown = study_input(given_name="", family_name="", medical_record_number=None, temporary_label="Unknown man")
    (photo, *_rest) = build(unknown).instances
    assert photo.PatientID == f"BE-{unknown.patient.id}" and str(photo.PatientName) == "Unknown man^"
    ruled = msgspec.structs.replace(study_input(), patient_id_rule=PatientIdRule.burnedge_id, patient_id_prefix="X-")
    assert {ds.PatientID for ds in build(ruled).instances} == {f"X-{ruled.patient.id}"}


@pytest.mark.parametrize("status", [AnalysisStatus.unscaled, AnalysisStatus.failed])
def test_an_unscaled_analysis_gets_no_figure_in_cm_nor_a_surface_and_a_failed_one_no_report(status):
    inputs = study_input()
    analysis = inputs.analyses[0]
    result = msgspec.structs.replace(
        analysis.record.result,
        status=status,
        metrics=msgspec.structs.replace(analysis.record.result.metrics, area_cm2=None, perimeter_cm=None),
        scale=ScaleSummary(method="none"),
    )
    record = msgspec.structs.replace(analysis.record, result=result)
    inputs = msgspec.structs.replace(inputs, analyses=[msgspec.structs.replace(analysis, record=record)])
    datasets = build(inputs).instances
    assert _of(datasets, EncapsulatedSTLStorage) == [] and _of(datasets, SurfaceScanMeshStorage) == []
    reports = _of(datasets, Comprehensive3DSRStorage)
    if status is AnalysisStatus.failed:
        assert reports == []
        return
    (group,) = MeasurementReport.from_sequence([reports[0]]).get_image_measurement_groups()
    names = {m.name.value for m in group.get_measurements()}
    assert "42798000" not in names and "131191004" not in names
    evaluations = {e.name.value: e.value.value for e in group.get_qualitative_evaluations()}
    assert evaluations["122421"] == "no-scale"
