"""The modules every object of the study shares (PS3.3): Patient, General Study, Patient Study, General Series,
General Equipment and SOP Common, and the file meta information (PS3.10)."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.sr.coding import Code
from pydicom.uid import PYDICOM_IMPLEMENTATION_UID, ExplicitVRLittleEndian

from processing.dicom import identity
from processing.dicom.inputs import StudyInput
from schemas.patient import Sex

MANUFACTURER = "burnedge"
SEX = {Sex.female: "F", Sex.male: "M", Sex.other: "O", Sex.unknown: ""}


@dataclass(frozen=True)
class Series:
    """One series of the study: what it holds, its number and modality."""

    role: str
    number: int
    modality: str
    description: str


PHOTOS = Series("photos", 1, "XC", "Burn photographs")
MEASUREMENTS = Series("measurements", 2, "SR", "Burn measurements (TID 1500)")
SURFACE = Series("surface", 3, "M3D", "3D burn surface (STL)")
REPORT = Series("report", 4, "DOC", "Burn assessment report (PDF)")
MESH = Series("mesh", 5, "OSS", "3D burn surface with the burn (mesh)")


def study_uid(study: StudyInput) -> str:
    return identity.uid("encounter", study.encounter.id, "study")


def series_uid(study: StudyInput, series: Series) -> str:
    return identity.uid("encounter", study.encounter.id, f"series/{series.role}")


def dataset(
    study: StudyInput,
    series: Series,
    sop_class: str,
    instance_uid: str,
    number: int,
    content_time: dt.datetime,
    transfer_syntax: str = ExplicitVRLittleEndian,
) -> Dataset:
    """A new instance of `sop_class` with the shared modules filled."""
    ds = Dataset()
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = sop_class
    meta.MediaStorageSOPInstanceUID = instance_uid
    meta.TransferSyntaxUID = transfer_syntax
    meta.ImplementationClassUID = PYDICOM_IMPLEMENTATION_UID
    ds.file_meta = meta
    ds.SpecificCharacterSet = "ISO_IR 192"
    ds.SOPClassUID = sop_class
    ds.SOPInstanceUID = instance_uid
    ds.TimezoneOffsetFromUTC = identity.offset(study)
    ds.InstanceCreationDate = identity.da(study, study.made_at)
    ds.InstanceCreationTime = identity.tm(study, study.made_at)
    patient(ds, study)
    general_study(ds, study)
    ds.Modality = series.modality
    ds.SeriesInstanceUID = series_uid(study, series)
    ds.SeriesNumber = series.number
    ds.SeriesDescription = series.description
    ds.Manufacturer = MANUFACTURER
    ds.SoftwareVersions = study.software_version or "unknown"
    if study.institution:
        ds.InstitutionName = study.institution[:64]
    ds.InstanceNumber = number
    ds.ContentDate = identity.da(study, content_time)
    ds.ContentTime = identity.tm(study, content_time)
    return ds


def coded(code: Code) -> Dataset:
    """A Code Sequence item (PS3.3 Table 8.8-1) of `code`."""
    item = Dataset()
    item.CodeValue, item.CodingSchemeDesignator, item.CodeMeaning = code.value, code.scheme_designator, code.meaning
    return item


def reference(instance: Dataset) -> Dataset:
    """A SOP Instance Reference item (PS3.3 Table 10-11) of `instance`."""
    item = Dataset()
    item.ReferencedSOPClassUID = instance.SOPClassUID
    item.ReferencedSOPInstanceUID = instance.SOPInstanceUID
    return item


def patient(ds: Dataset, study: StudyInput) -> None:
    p = study.patient
    ds.PatientName = identity.patient_name(study)
    ds.PatientID = identity.patient_id(study)
    if study.issuer_of_patient_id:
        ds.IssuerOfPatientID = study.issuer_of_patient_id[:64]
    ds.PatientBirthDate = p.date_of_birth.strftime("%Y%m%d") if p.date_of_birth else ""
    ds.PatientSex = SEX[p.sex]
    if p.weight_kg is not None or study.encounter.weight_kg is not None:
        ds.PatientWeight = f"{study.encounter.weight_kg or p.weight_kg:.1f}"
    if p.height_cm is not None:
        ds.PatientSize = f"{p.height_cm / 100:.2f}"


def general_study(ds: Dataset, study: StudyInput) -> None:
    arrival = study.encounter.time_of_arrival
    ds.StudyInstanceUID = study_uid(study)
    ds.StudyDate = identity.da(study, arrival)
    ds.StudyTime = identity.tm(study, arrival)
    ds.ReferringPhysicianName = ""
    ds.AccessionNumber = ""
    ds.StudyID = study.encounter.id.replace("-", "")[-16:]
    ds.StudyDescription = "Burn assessment"
    if study.encounter.clinician:
        ds.PhysiciansOfRecord = identity.one_name(study.encounter.clinician)
