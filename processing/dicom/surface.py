"""The analysis's 3D surface as an Encapsulated STL (PS3.3 A.85, Supplement 205): the reconstructed skin surface
as binary STL in millimetres, converted from the painted glTF binary with trimesh.

It is written beside the Surface Scan Mesh (processing/dicom/mesh.py), which carries the burn, because more
viewers open an STL (3D Slicer, Orthanc's STL viewer, 3D printing software) than a Surface Scan Mesh. STL has no
colours: the burn is in the mesh and the SR's figures. Only a scaled analysis (millimetres) is exported: an
unscaled mesh has no unit DICOM could name.
"""

from __future__ import annotations

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
    ds.MeasurementUnitsCodeSequence = [common.coded(codes.UCUM.Millimeter)]
    ds.AcquisitionDateTime = ""
    ds.BurnedInAnnotation = "NO"
    ds.DocumentTitle = f"3D burn surface, analysis {record.job_id}"
    ds.ConceptNameCodeSequence = [common.coded(codes.DCM.PhotogrammetricImaging3DCAMModel)]  # CID 7061
    ds.MIMETypeOfEncapsulatedDocument = "model/stl"
    ds.EncapsulatedDocument = stl + (b"\0" if len(stl) % 2 else b"")
    ds.EncapsulatedDocumentLength = len(stl)
    if photos:
        ds.SourceInstanceSequence = [common.reference(p) for p in photos]
        # Common Instance Reference: the series (of this study) that holds the instances referenced above.
        series = Dataset()
        series.SeriesInstanceUID = photos[0].SeriesInstanceUID
        series.ReferencedInstanceSequence = [common.reference(p) for p in photos]
        ds.ReferencedSeriesSequence = [series]
    return ds
