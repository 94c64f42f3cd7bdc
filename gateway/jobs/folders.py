"""Where each analysis job keeps its files, which of them a user may download, and the retention clean-up.

WORK/<job id>/source/<stem>.<ext>         the pictures, linked from the media store (stem: PictureRef.stem)
WORK/<job id>/masks/<stem>.png|.json      a clinician's masks or outlines
WORK/<job id>/ruler.json                  ruler points, when given
WORK/<job id>/analysis/                   the analysis folder (processing/analysis/pipeline.py)
WORK/<job id>/logs/try-<n>.log            what each try's process wrote (native crashes print only there)
WORK/patients/<patient id>/               the patient's healing track (track.json)
"""

from __future__ import annotations

import datetime as dt
import logging
import re
import shutil
from pathlib import Path

from base.folders import analysis_dir, job_dir, matching_files, media_root, patient_dir, work_root
from gateway.storage import jobs
from gateway.storage.database import Database
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.errors import NotFound
from schemas.jobs import JobState

log = logging.getLogger("burnedge.jobs")

# The folders of a job and of a patient are resolved in base/folders.py, with every other default folder.
__all__ = [
    "DELIVERABLES",
    "SCRATCH",
    "analysis_dir",
    "artifact_file",
    "artifacts",
    "clean_up",
    "job_dir",
    "patient_dir",
    "without_server_paths",
    "work_root",
]

DELIVERABLES = (
    "analysis.json",
    "report.json",
    "mesh/surface.glb",
    "mesh/surface.ply",
    "surface/burn_surface.glb",
    "metrics/metrics.json",
    "segmentation/segmentation.json",
    "segmentation/masks/*.png",
    "segmentation/overlays/*.jpg",
    "segmentation/probability/*.png",
)
"""What an analysis keeps after the retention period, and all a user may download from it."""
SCRATCH = ("source", "masks", "analysis/images", "analysis/sfm/database.db", "analysis/sfm/work", "analysis/dense")
"""What the retention clean-up removes from a finished analysis: copies of the pictures (the media store keeps
them), the feature database and the depth maps. The mesh and the painted burn stay for the healing track."""


def artifacts(config: Config, job_id: str, patterns: tuple[str, ...] = DELIVERABLES) -> list[str]:
    """The downloadable files of a job (or those matching `patterns`), relative to its analysis folder."""
    return matching_files(analysis_dir(config, job_id), patterns)


def artifact_file(config: Config, job_id: str, name: str) -> Path:
    """One downloadable file; anything else (another path, `..`) is not found."""
    if name not in artifacts(config, job_id):
        raise NotFound(f"analysis {job_id} has no file {name!r}; GET its artifacts for the list")
    return analysis_dir(config, job_id) / name


def clean_up(db: Database, config: Config) -> int:
    """Apply the retention period to finished jobs' folders; returns how many were cleaned."""
    cutoff = iso(utcnow() - dt.timedelta(days=config.jobs.retention_days))
    expired = jobs.past_retention(db.connection(), cutoff)
    for job in expired:
        folder = job_dir(config, job.id)
        if job.state is JobState.done:
            for part in SCRATCH:
                path = folder / part
                if path.is_dir():
                    shutil.rmtree(path, ignore_errors=True)
                else:
                    path.unlink(missing_ok=True)
        else:
            shutil.rmtree(folder, ignore_errors=True)
        with db.write() as conn:
            jobs.mark_cleaned(conn, job.id, iso(utcnow()))
        log.info(
            "analysis %s (%s): work files past the %g-day retention removed",
            job.id,
            job.state.value,
            config.jobs.retention_days,
        )
    return len(expired)


_SITE_PACKAGES = re.compile(r"(?:/[^\s\"':]+)+/site-packages/")


def without_server_paths(config: Config, text: str) -> str:
    """`text` (a log) with the gateway's folders and its Python installation's paths shortened, for the API."""
    text = text.replace(str(work_root(config)), "<analyses>").replace(str(media_root(config)), "<media>")
    text = _SITE_PACKAGES.sub("<python>/", text)
    return text.replace(str(Path(__file__).resolve().parents[2]) + "/", "")
