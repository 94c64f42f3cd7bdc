"""The painted burn surface as Surface Scan Mesh Storage (PS3.3 A.68): the reconstructed skin surface and the burn
on it as two surfaces of one Surface Mesh module, in millimetres, in the analysis's Frame of Reference.

The burn is read from the painted glTF itself (processing/analysis/paint.py), which is all the burn center
receives, so the clinic and the center write the same object: a vertex belongs to the burn where the paint makes
up at least its share at the burn's boundary (q >= 0.5), and the burn surface is the triangles whose three corners
do. DICOM has no per-vertex colour in a mesh; each surface carries its Recommended Display CIELab Value instead.
"""

from __future__ import annotations

import datetime as dt
import io
from dataclasses import dataclass

import numpy as np
from highdicom.color import CIELabColor
from pydicom.dataset import Dataset
from pydicom.sr.codedict import codes
from pydicom.sr.coding import Code
from pydicom.uid import SurfaceScanMeshStorage

from processing.analysis import paint
from processing.analysis.burn_region import LEVEL
from processing.dicom import anatomy, common, identity
from processing.dicom.inputs import Analysis, StudyInput

ROUNDING = 0.02
"""The glTF's colours are 8-bit: a vertex painted exactly at the boundary may read a little under its share."""
SKIN_GREY = np.array([0.7, 0.7, 0.7])
"""What burn_surface.glb gives a mesh that had no colours of its own."""
UNPAINTED = 0.1
"""A vertex with less paint than this is the skin's own colour (give or take its variation)."""
ALGORITHM = "burnedge 3D burn analysis"
BURN_INJURY = Code("48333001", "SCT", "Burn injury")
"""SNOMED CT 48333001 |Burn injury (morphologic abnormality)|, as a Segmented Property Type under CID 7150's
Morphologically Abnormal Structure (docs/dicom.md: not in pydicom's dictionary)."""


@dataclass(frozen=True)
class Painted:
    """The glTF's mesh (mm) and how much of each vertex's colour is the burn's paint (0..MAX_ALPHA)."""

    vertices: np.ndarray
    faces: np.ndarray
    colours: np.ndarray
    share: np.ndarray

    def burn_faces(self) -> np.ndarray:
        painted = self.share >= paint.alpha_at(LEVEL) - ROUNDING
        return self.faces[np.all(painted[self.faces], axis=1)]

    def skin_colour(self) -> np.ndarray:
        unpainted = self.share < UNPAINTED
        return np.median(self.colours[unpainted], axis=0) if unpainted.any() else SKIN_GREY


def instance_uid(job_id: str) -> str:
    return identity.uid("burn_analysis", job_id, "surface-scan-mesh")


def painted(glb: bytes) -> Painted:
    import trimesh

    mesh = trimesh.load(io.BytesIO(glb), file_type="glb", force="mesh", process=False)
    vertices = np.asarray(mesh.vertices, np.float64)
    coloured = mesh.visual.kind == "vertex"
    colours = (
        np.asarray(mesh.visual.vertex_colors)[:, :3] / 255.0 if coloured else np.tile(SKIN_GREY, (len(vertices), 1))
    )
    return Painted(vertices, np.asarray(mesh.faces, np.int64), colours, _paint_share(colours))


def _paint_share(colours: np.ndarray) -> np.ndarray:
    """Each vertex's paint share, its colour seen as the skin's (the median of the unpainted vertices) blended
    towards the paint."""
    skin = np.median(colours, axis=0)
    share = np.zeros(len(colours))
    for _ in range(2):
        towards = paint.PAINT - skin
        share = np.clip((colours - skin) @ towards / max(float(towards @ towards), 1e-9), 0, 1)
        unpainted = share < UNPAINTED
        if not unpainted.any():
            break
        skin = np.median(colours[unpainted], axis=0)
    return share


def mesh(study: StudyInput, analysis: Analysis, number: int) -> Dataset:
    record = analysis.record
    completed = identity.parse_iso(record.completed_at) or study.made_at
    ds = common.dataset(study, common.MESH, SurfaceScanMeshStorage, instance_uid(record.job_id), number, completed)
    del ds.ContentDate, ds.ContentTime  # not in this IOD: Acquisition DateTime says when
    surface = painted(analysis.surface_glb or b"")
    ds.FrameOfReferenceUID = identity.uid("burn_analysis", record.job_id, "frame-of-reference")
    ds.PositionReferenceIndicator = ""
    side = anatomy.site(study.wound(record.wound_id))
    ds.Laterality = side[1][1] if side and side[1] and side[1][1] in ("L", "R") else ""
    ds.ManufacturerModelName = ALGORITHM
    ds.DeviceSerialNumber = "none"
    _scan_procedure(ds, study, analysis, completed)
    surfaces = [
        _surface(
            1,
            surface.vertices,
            surface.faces,
            "the reconstructed skin surface, in mm",
            (codes.SCT.Tissue, codes.SCT.Skin),
            surface.skin_colour(),
        )
    ]
    burn = surface.burn_faces()
    if len(burn):
        used, faces = np.unique(burn, return_inverse=True)
        item = _surface(
            2,
            surface.vertices[used],
            faces.reshape(-1, 3),
            "the burn: where the fused burn probability is at least 0.5 on all three corners of a triangle",
            (codes.SCT.MorphologicallyAbnormalStructure, BURN_INJURY),
            paint.PAINT,
        )
        surfaces.append(item)
    ds.NumberOfSurfaces = len(surfaces)
    ds.SurfaceSequence = surfaces
    return ds


def _scan_procedure(ds: Dataset, study: StudyInput, analysis: Analysis, done: dt.datetime) -> None:
    """Scan Procedure: the photos are the scan; its start is the first camera time, its length their span."""
    times = sorted(p.taken_at for p in study.photos if p.taken_at and p.asset_id in analysis.record.assets)
    start = times[0] if times else (identity.parse_iso(analysis.record.requested_at) or done)
    ds.AcquisitionDateTime = identity.dt_value(study, start)
    ds.SurfaceScanAcquisitionTypeCodeSequence = [common.coded(codes.DCM.ShapeFromMotion)]  # CID 8201
    ds.SurfaceScanModeCodeSequence = []
    ds.ShotDurationTime = (times[-1] - times[0]).total_seconds() if times else 0.0


def _surface(number: int, vertices, faces, comments: str, property_codes, rgb) -> Dataset:
    import trimesh

    tri = trimesh.Trimesh(vertices=vertices, faces=faces, process=False)
    colour = CIELabColor.from_rgb(*(int(round(c * 255)) for c in np.clip(rgb, 0, 1)))
    item = Dataset()
    item.SurfaceNumber = number
    item.SurfaceComments = comments
    item.SegmentedPropertyCategoryCodeSequence = [common.coded(property_codes[0])]
    item.SegmentedPropertyTypeCodeSequence = [common.coded(property_codes[1])]
    # Neither surface was decimated or smoothed after the reconstruction: the burn is a selection of the skin's
    # triangles, told by its Segmented Property codes, not a processing of the surface.
    item.SurfaceProcessing = "NO"
    item.RecommendedDisplayGrayscaleValue = colour.value[0]
    item.RecommendedDisplayCIELabValue = list(colour.value)
    item.RecommendedPresentationOpacity = 1.0
    item.RecommendedPresentationType = "SURFACE"
    item.FiniteVolume = "YES" if tri.is_watertight else "NO"
    item.Manifold = "UNKNOWN"
    points = Dataset()
    points.NumberOfSurfacePoints = len(vertices)
    points.PointCoordinatesData = np.asarray(vertices, "<f4").tobytes()
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    points.PointsBoundingBoxCoordinates = [float(v) for v in (*low, *high)]
    item.SurfacePointsSequence = [points]
    normals = Dataset()
    normals.NumberOfVectors = len(vertices)
    normals.VectorDimensionality = 3
    normals.VectorCoordinateData = np.asarray(tri.vertex_normals, "<f4").tobytes()
    item.SurfacePointsNormalsSequence = [normals]
    primitives = Dataset()
    # Point indices in DICOM count from 1 (PS3.3 C.27.2.1.1, referred to by C.27.4.1).
    primitives.LongTrianglePointIndexList = (np.asarray(faces, "<u4") + 1).tobytes()
    for empty in ("LongEdgePointIndexList", "LongVertexPointIndexList"):  # Type 2: present, empty
        setattr(primitives, empty, b"")
    for empty in ("TriangleStripSequence", "TriangleFanSequence", "LineSequence", "FacetSequence"):
        setattr(primitives, empty, [])
    item.SurfaceMeshPrimitivesSequence = [primitives]
    return item
