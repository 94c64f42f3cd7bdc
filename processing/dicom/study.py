"""An encounter as one DICOM study: its photos, each analysis's measurement report and surface, and the clinical
report; written as files (PS3.10) or handed to the DICOMweb client (processing/dicom/web.py).

    build(StudyInput) -> Study
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

from pydicom import dcmread
from pydicom.dataset import Dataset

from base.storage.durable import replace_atomically
from processing.dicom import common, measurements, mesh, photo, report, surface
from processing.dicom.inputs import StudyInput
from schemas.analysis import AnalysisStatus


@dataclass(frozen=True)
class Study:
    study_uid: str
    instances: list[Dataset]

    def files(self) -> list[tuple[str, bytes]]:
        """(file name, Part 10 bytes) of each instance, in order: photos, reports, STL surfaces, the PDF, meshes."""
        out = []
        for ds in self.instances:
            buffer = io.BytesIO()
            ds.save_as(buffer, enforce_file_format=True)
            out.append((f"{ds.Modality.lower()}-{ds.SeriesNumber}-{ds.InstanceNumber:03d}.dcm", buffer.getvalue()))
        return out

    def write(self, folder: Path) -> list[Path]:
        folder.mkdir(parents=True, exist_ok=True)
        written = []
        for name, data in self.files():
            path = folder / name
            replace_atomically(path, data)
            written.append(path)
        return written


def build(study: StudyInput) -> Study:
    photos = {p.asset_id: photo.photo(study, p, number) for number, p in enumerate(study.photos, start=1)}
    instances: list[Dataset] = list(photos.values())
    reports, surfaces, meshes = [], [], []
    for analysis in study.analyses:
        if analysis.record.result.status is AnalysisStatus.failed:
            continue
        used = [photos[a] for a in analysis.record.assets if a in photos]
        if used:  # the SR's evidence: a report must reference the photos it was measured from
            reports.append(measurements.report(study, analysis, used, len(reports) + 1))
        if surface.exportable(analysis):
            surfaces.append(surface.surface(study, analysis, used, len(surfaces) + 1))
            meshes.append(mesh.mesh(study, analysis, len(meshes) + 1))
    instances += reports + surfaces
    if study.report_pdf:
        instances.append(report.report_pdf(study, study.report_pdf, 1))
    instances += meshes
    for ds in instances:
        # With a preamble, pydicom writes the full Part 10 file (preamble, "DICM", file meta) wherever the dataset
        # is written as it stands, as dicomweb-client does for STOW-RS: a PACS is sent files, not bare datasets.
        ds.preamble = b"\0" * 128
    return Study(common.study_uid(study), instances)


def read_back(data: bytes) -> Dataset:
    return dcmread(io.BytesIO(data))
