"""Every default folder, in one place: an empty setting means a folder beside the server's database.

The database's path is resolved first, so a relative [gateway] database gives the same folders whatever the
working directory of a later process (the worker, the CLI, the backup timer) is.
"""

from __future__ import annotations

from pathlib import Path

from base.storage.dialect import is_postgres
from schemas.config import CentralConfig, Config
from schemas.errors import InvalidInput


def beside(database: str | Path, setting: str, default_name: str) -> Path:
    """`setting` when given, else `default_name` in the folder that holds `database`."""
    if setting:
        return Path(setting)
    return Path(database).resolve().parent / default_name


def media_root(config: Config) -> Path:
    """The gateway's media store: [uploads] data_dir, or "burnedge-media" beside the database."""
    return beside(config.gateway.database, config.uploads.data_dir, "burnedge-media")


def work_root(config: Config) -> Path:
    """The analysis queue's work folders: [jobs] work_dir, or "burnedge-analyses" beside the database."""
    return beside(config.gateway.database, config.jobs.work_dir, "burnedge-analyses")


def reports_root(config: Config) -> Path:
    """The clinical reports made: [report] reports_dir, or "burnedge-reports" beside the database."""
    return beside(config.gateway.database, config.report.reports_dir, "burnedge-reports")


def job_dir(config: Config, job_id: str) -> Path:
    return work_root(config) / job_id


def analysis_dir(config: Config, job_id: str) -> Path:
    """The analysis folder of one job (processing/analysis/pipeline.py writes it)."""
    return job_dir(config, job_id) / "analysis"


def patient_dir(config: Config, patient_id: str) -> Path:
    """Where a patient's healing track is kept."""
    return work_root(config) / "patients" / patient_id


def outbox_root(config: Config) -> Path:
    """Sealed bundles waiting for the burn center: [sync] outbox_dir, or "burnedge-outbox" beside the database."""
    return beside(config.gateway.database, config.sync.outbox_dir, "burnedge-outbox")


def keys_dir(config: Config) -> Path:
    """The clinic's site keys (and the center's newest audit anchor): [sync] keys_dir, or "burnedge-keys"."""
    return beside(config.gateway.database, config.sync.keys_dir, "burnedge-keys")


def center_store_dir(central: CentralConfig) -> Path:
    """The burn center's received parts: [central] store_dir, or "burnedge-central-store" beside its database."""
    return _center_folder(central, central.store_dir, "store_dir", "burnedge-central-store")


def center_keys_dir(central: CentralConfig) -> Path:
    """The burn center's site keys: [central] keys_dir, or "burnedge-central-keys" beside its database."""
    return _center_folder(central, central.keys_dir, "keys_dir", "burnedge-central-keys")


def _center_folder(central: CentralConfig, setting: str, name: str, default_name: str) -> Path:
    if not setting and is_postgres(central.database):
        raise InvalidInput(
            f"[central] {name} must be set when the database is PostgreSQL: there is no file to put it beside"
        )
    return beside(central.database, setting, default_name)


def matching_files(folder: Path, patterns: tuple[str, ...]) -> list[str]:
    """The files under `folder` that match any of the glob `patterns`, relative to it, sorted."""
    return sorted({str(p.relative_to(folder)) for pattern in patterns for p in folder.glob(pattern) if p.is_file()})
