"""The clinical report as an Encapsulated PDF (PS3.3 A.45.1), the PDF's bytes as made for the same encounter."""

from __future__ import annotations

from pydicom.dataset import Dataset
from pydicom.uid import EncapsulatedPDFStorage

from processing.dicom import common, identity
from processing.dicom.inputs import StudyInput


def instance_uid(encounter_id: str) -> str:
    return identity.uid("encounter", encounter_id, "report-pdf")


def report_pdf(study: StudyInput, pdf: bytes, number: int) -> Dataset:
    ds = common.dataset(
        study, common.REPORT, EncapsulatedPDFStorage, instance_uid(study.encounter.id), number, study.made_at
    )
    ds.ConversionType = "WSD"
    ds.BurnedInAnnotation = "YES"  # the report prints the patient's name and identifiers
    ds.DocumentTitle = "Burn assessment report"
    ds.ConceptNameCodeSequence = []
    ds.MIMETypeOfEncapsulatedDocument = "application/pdf"
    ds.EncapsulatedDocument = pdf + (b"\0" if len(pdf) % 2 else b"")
    ds.EncapsulatedDocumentLength = len(pdf)
    ds.AcquisitionDateTime = identity.dt_value(study, study.made_at)
    return ds
