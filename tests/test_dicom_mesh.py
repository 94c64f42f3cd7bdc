"""The painted surface as a Surface Scan Mesh (processing/dicom/mesh.py), and every object the study writes checked
by dicom3tools' dciodvfy (its IOD and module rules, PS3.3) and dcentvfy (one patient and study across the files).
dicom3tools comes from Debian (deploy/bootstrap.sh --test); the checks skip, saying so, where it is missing."""

from __future__ import annotations

import io
import re
import shutil
import subprocess

import numpy as np
import pytest
from highdicom.color import CIELabColor
from pydicom import dcmread
from pydicom.uid import EncapsulatedSTLStorage, SurfaceScanMeshStorage

from processing.analysis import paint
from processing.dicom.study import build
from tests.dicom_inputs import SKIN, study_input

ALLOWED_WARNINGS = (
    "needed to build DICOMDIR",  # a DICOMDIR is not written: the files go to a PACS
    "Unrecognized defined term <99BURNEDGE>",  # burnedge's private coding scheme, declared in the SR
    "is only permitted to be empty when actually unknown",  # a photo of no known wound: its side is unknown
)
MESH_MODULES = ("SurfaceMesh", "SurfaceMeshPrimitivesMacro", "PointsMacro", "VectorsMacro")
MESH_MODULES += ("AlgorithmIdentificationMacro", "CodeSequenceMacro")


def _datasets(inputs=None):
    return [dcmread(io.BytesIO(data)) for _name, data in build(inputs or study_input()).files()]


def _one(datasets, sop_class):
    (found,) = [ds for ds in datasets if ds.SOPClassUID == sop_class]
    return found


def _points(surface) -> np.ndarray:
    return np.frombuffer(surface.SurfacePointsSequence[0].PointCoordinatesData, "<f4").reshape(-1, 3)


def _triangles(surface) -> np.ndarray:
    return np.frombuffer(surface.SurfaceMeshPrimitivesSequence[0].LongTrianglePointIndexList, "<u4").reshape(-1, 3)


def test_the_mesh_holds_the_skin_and_the_burn_as_two_surfaces_in_mm_in_the_stls_frame_of_reference():
    inputs = study_input()
    datasets = _datasets(inputs)
    mesh, stl = _one(datasets, SurfaceScanMeshStorage), _one(datasets, EncapsulatedSTLStorage)
    assert mesh.Modality == "OSS" and mesh.FrameOfReferenceUID == stl.FrameOfReferenceUID
    assert mesh.AcquisitionDateTime == "20261113053500+0100"  # the first photo's camera clock
    assert mesh.SurfaceScanAcquisitionTypeCodeSequence[0].CodeValue == "114206"  # DCM Shape from motion
    assert mesh.Laterality == "L"  # the wound's side
    skin, burn = mesh.SurfaceSequence
    assert mesh.NumberOfSurfaces == 2 and (skin.SurfaceNumber, burn.SurfaceNumber) == (1, 2)
    everything, burnt = _points(skin), _points(burn)
    assert sorted(round(float(x)) for x in everything.max(axis=0) - everything.min(axis=0)) == [5, 30, 40]  # mm
    assert len(burnt) < len(everything) and np.all(burnt[:, 0] > 0)  # the painted half, nothing of the rest
    for surface, points in ((skin, everything), (burn, burnt)):
        triangles = _triangles(surface)
        assert triangles.min() == 1 and triangles.max() == len(points)  # indices count from 1
        assert surface.SurfacePointsSequence[0].NumberOfSurfacePoints == len(points)
        normals = surface.SurfacePointsNormalsSequence[0]
        assert normals.NumberOfVectors == len(points) and len(normals.VectorCoordinateData) == 12 * len(points)
    assert skin.SegmentedPropertyTypeCodeSequence[0].CodeValue == "39937001"  # SCT Skin
    assert burn.SegmentedPropertyCategoryCodeSequence[0].CodeValue == "49755003"  # Morphologically abnormal structure
    assert burn.SegmentedPropertyTypeCodeSequence[0].CodeValue == "48333001"  # Burn injury
    assert tuple(burn.RecommendedDisplayCIELabValue) == CIELabColor.from_rgb(255, 41, 199).value  # the paint
    skin_rgb = CIELabColor.from_dicom_value(tuple(skin.RecommendedDisplayCIELabValue)).to_rgb()
    assert np.abs(np.array(skin_rgb) - SKIN * 255).max() <= 3  # the skin's own colour, not the paint's
    assert skin.SurfaceProcessing == burn.SurfaceProcessing == "NO"  # a selection of triangles, not reprocessed
    assert skin.FiniteVolume == "YES" and burn.FiniteVolume == "NO"  # the closed box; half of it is open


def test_a_surface_with_no_paint_has_the_skin_alone():
    import msgspec
    import trimesh

    inputs = study_input()
    plain = trimesh.creation.box(extents=(40, 30, 5)).export(file_type="glb")
    analyses = [msgspec.structs.replace(inputs.analyses[0], surface_glb=plain)]
    mesh = _one(_datasets(msgspec.structs.replace(inputs, analyses=analyses)), SurfaceScanMeshStorage)
    assert mesh.NumberOfSurfaces == 1 and len(_points(mesh.SurfaceSequence[0])) == 8
    assert paint.alpha_at(0.5) == pytest.approx(0.4)  # the share the burn's boundary is read at


def test_the_burn_read_from_the_paint_is_where_the_fused_probability_is_at_least_a_half():
    """The paint over a skin whose colour varies from vertex to vertex, stored in 8 bits as burn_surface.glb is:
    every vertex with q >= 0.5 is read as burn, and next to none below."""
    import trimesh

    from processing.dicom.mesh import painted

    rng = np.random.default_rng(7)
    grid = trimesh.creation.box(extents=(60, 60, 1)).subdivide().subdivide().subdivide().subdivide()
    q = np.exp(-np.sum(grid.vertices[:, :2] ** 2, axis=1) / (2 * 12.0**2))  # a burn in the middle, fading out
    q[grid.vertices[:, 0] > 25] = np.nan  # not looked at
    skin = np.clip(SKIN + rng.normal(0, 0.03, (len(q), 3)), 0, 1)
    alpha = paint.alpha(q)[:, None]
    colours = ((skin * (1 - alpha) + paint.PAINT * alpha) * 255).round().astype(np.uint8)
    glb = trimesh.exchange.gltf.export_glb(
        trimesh.Scene(trimesh.Trimesh(grid.vertices, grid.faces, process=False, vertex_colors=colours))
    )
    surface = painted(glb)
    read = surface.share >= paint.alpha_at(0.5) - 0.02
    truth = np.nan_to_num(q) >= 0.5
    assert truth.sum() > 50 and np.all(read[truth])  # no burn vertex lost
    assert (read & ~truth).sum() <= 0.03 * truth.sum()  # and few taken from the edge around it


def _dicom3tools() -> None:
    if not (shutil.which("dciodvfy") and shutil.which("dcentvfy")):
        pytest.skip("dicom3tools is not installed (apt-get install dicom3tools; deploy/bootstrap.sh --test does)")


def _verify(path) -> tuple[list[str], list[str]]:
    out = subprocess.run(["dciodvfy", str(path)], capture_output=True, text=True, timeout=60)
    lines = (out.stdout + out.stderr).splitlines()
    errors = [line for line in lines if line.startswith("Error")]
    warnings = [w for w in lines if w.startswith("Warning") and not any(a in w for a in ALLOWED_WARNINGS)]
    return errors, warnings


def test_dciodvfy_finds_no_error_in_any_object_and_dcentvfy_one_patient_and_study(tmp_path):
    _dicom3tools()
    written = build(study_input()).write(tmp_path)
    kinds = set()
    for path in written:
        ds = dcmread(path, stop_before_pixels=True)
        kinds.add(ds.Modality)
        errors, warnings = _verify(path)
        if ds.SOPClassUID == SurfaceScanMeshStorage:
            # dicom3tools (Debian's 2022 build, and 2024's) has no Surface Scan Mesh IOD: it says so and checks no
            # module. Its Surface Mesh module rules are checked below, through the Surface Segmentation IOD.
            assert errors == ["Error - Information Object Not found"], errors
            continue
        assert errors == [] and warnings == [], (path.name, errors, warnings)
    assert kinds == {"XC", "SR", "M3D", "DOC", "OSS"}
    entities = subprocess.run(["dcentvfy", *map(str, written)], capture_output=True, text=True, timeout=60)
    assert not re.search(r"^Error", entities.stdout + entities.stderr, re.MULTILINE), entities.stdout


def test_dciodvfy_finds_no_error_in_the_surface_mesh_module(tmp_path):
    """The mesh's Surface Mesh module (PS3.3 C.27.1) under dciodvfy's rules for it: the object relabelled as a
    Surface Segmentation, which has the same module, and only that module's findings kept."""
    _dicom3tools()
    mesh = _one(_datasets(), SurfaceScanMeshStorage)
    mesh.SOPClassUID = mesh.file_meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.66.5"
    mesh.Modality = "SEG"
    mesh.save_as(tmp_path / "relabelled.dcm")
    errors, _warnings = _verify(tmp_path / "relabelled.dcm")
    assert any("SegmentSequence" in e for e in errors)  # the Segmentation's own module: the rules did run
    mine = [e for e in errors if any(f"Module=<{module}>" in e for module in MESH_MODULES)]
    assert mine == []
