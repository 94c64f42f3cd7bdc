"""The analysis's 3D surface as an Encapsulated STL (PS3.3 A.85, Supplement 205): the reconstructed skin surface
as binary STL in millimetres, converted from the painted glTF binary with trimesh.

Why not Surface Scan Mesh Storage: its IOD needs the Surface Mesh module's point, normal and primitive sequences,
which pydicom and highdicom do not build and few viewers read; Encapsulated STL is read by PACS and 3D viewers as a
file. STL has no colours: the burn's paint stays in the glTF that the FHIR export and the case bundle carry, and
its outline is in the SR's figures. Only a scaled analysis (millimetres) is exported: an unscaled mesh has no unit
DICOM could name.
"""

from __future__ import annotations

import hashlib
import io

from pydicom.dataset import Dataset
from pydicom.sr.codedict import codes
from pydicom.uid import EncapsulatedSTLStorage

from processing.dicom import common, identity
from processing.dicom.inputs import Analysis, StudyInput
from schemas.analysis import AnalysisStatus


def instance_uid(job_id: str) -> str:
    return identity.uid("burn_analysis", job_id, "encapsulated-stl")


def stl_of(glb: bytes) -> bytes:
    import trimesh

    mesh = trimesh.load(io.BytesIO(glb), file_type="glb", force="mesh")
    return mesh.export(file_type="stl")


def exportable(analysis: Analysis) -> bool:
    result = analysis.record.result
    scaled = result.status is AnalysisStatus.ok and result.scale is not None and bool(result.scale.mm_per_unit)
    return scaled and analysis.surface_glb is not None


def surface(study: StudyInput, analysis: Analysis, photos: list[Dataset], number: int) -> Dataset:
    record = analysis.record
    completed = identity.parse_iso(record.completed_at) or study.made_at
    ds = common.dataset(study, common.SURFACE, EncapsulatedSTLStorage, instance_uid(record.job_id), number, completed)
    stl = stl_of(analysis.surface_glb or b"")
    ds.FrameOfReferenceUID = identity.uid("burn_analysis", record.job_id, "frame-of-reference")
    ds.PositionReferenceIndicator = ""
    ds.ManufacturerModelName = "burnedge 3D burn analysis"
    ds.DeviceSerialNumber = "none"
    ds.MeasurementUnitsCodeSequence = [_coded(codes.UCUM.Millimeter)]
    ds.BurnedInAnnotation = "NO"
    ds.DocumentTitle = f"3D burn surface, analysis {record.job_id}"
    ds.ConceptNameCodeSequence = [_coded(codes.DCM.PhotogrammetricImaging3DCAMModel)]  # CID 7061
    ds.MIMETypeOfEncapsulatedDocument = "model/stl"
    ds.EncapsulatedDocument = stl + (b"\0" if len(stl) % 2 else b"")
    ds.EncapsulatedDocumentLength = len(stl)
    ds.ImageComments = f"sha256 of the STL: {hashlib.sha256(stl).hexdigest()}"
    if photos:
        ds.SourceInstanceSequence = [_reference(p) for p in photos]
    return ds


def _coded(code) -> Dataset:
    item = Dataset()
    item.CodeValue, item.CodingSchemeDesignator, item.CodeMeaning = code.value, code.scheme_designator, code.meaning
    return item


def _reference(photo: Dataset) -> Dataset:
    item = Dataset()
    item.ReferencedSOPClassUID = photo.SOPClassUID
    item.ReferencedSOPInstanceUID = photo.SOPInstanceUID
    return item
