"""What the gateway's state is, where each part lives, and one consistent copy of it while the gateway runs.

The order is what makes the copy consistent:
1. the keys folder is read first (small files, replaced by rename): the burn center's audit anchor kept there then
   never names a later audit entry than the database copy holds;
2. the database is copied through SQLite's backup API in one step, a snapshot of one moment (WAL: writers go on);
3. from that copy, and only from it: which blobs, finished analyses and queued bundles to take. Blobs are stored
   under their SHA-256 and never change; a finished analysis's files were written before it was marked done; a
   bundle's chunks are synced before its outbox row commits. So nothing the snapshot refers to is half-written,
   and each copied blob is hashed again against its name. Uploads still in progress are left out (the phone
   sends them again: their offset starts at 0), and so are analyses not yet finished (they run again).
"""

from __future__ import annotations

import fcntl
import json
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from base.folders import keys_dir, media_root, outbox_root, work_root
from gateway.jobs.folders import SCRATCH
from gateway.storage import backup_copy
from schemas.audit import AuditHead
from schemas.config import Config
from sync.keys import PUBLIC_FILE
from sync.outbox import SEALED_FILE

STAGING_PREFIX = ".burnedge-backup-"


@dataclass(frozen=True)
class StateLayout:
    """Where each part of a gateway's state lives (from the configuration)."""

    database: Path
    media: Path
    analyses: Path
    outbox: Path
    keys: Path

    @classmethod
    def of(cls, config: Config) -> StateLayout:
        return cls(
            database=Path(config.gateway.database),
            media=media_root(config),
            analyses=work_root(config),
            outbox=outbox_root(config),
            keys=keys_dir(config),
        )


@dataclass
class Snapshot:
    """The database copy and what it refers to; `files` are (name in the archive, path on disk)."""

    database: Path
    audit_head: AuditHead | None
    migrations: list[str]
    site_id: str | None
    keys: dict[str, bytes]
    blobs: list[tuple[str, Path, str]]
    files: list[tuple[str, Path]]
    outbox: list[tuple[str, Path]]


def read_keys(folder: Path) -> dict[str, bytes]:
    if not folder.is_dir():
        return {}
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file() and not p.name.endswith(".tmp")}


@contextmanager
def take(config: Config) -> Iterator[Snapshot]:
    """The snapshot, staged in a private folder beside the database (no less protected than the database); the
    folder is removed afterwards."""
    layout = StateLayout.of(config)
    keys = read_keys(layout.keys)
    parent = layout.database.resolve().parent
    _remove_stale_staging(parent)
    staging = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=parent))
    lock = open(staging / ".lock", "w")  # held while in use: a later backup removes only unlocked, stale ones
    fcntl.flock(lock, fcntl.LOCK_EX)
    try:
        copy = staging / layout.database.name
        backup_copy.copy_database(layout.database, copy)
        yield _refer(backup_copy.read_contents(copy), copy, layout, keys)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        lock.close()


def _remove_stale_staging(parent: Path) -> None:
    """Database copies left by a backup that was killed (each holds a plain copy of the database)."""
    for folder in parent.glob(STAGING_PREFIX + "*"):
        try:
            with open(folder / ".lock", "a") as lock:
                fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
                shutil.rmtree(folder, ignore_errors=True)
        except OSError:  # in use by a running backup (or not ours to remove)
            continue


def _outbox_files(folder: Path, chunks: int) -> list[str]:
    """A queued bundle's sealed file, or its file per chunk when an older gateway queued it."""
    if (folder / SEALED_FILE).exists():
        return [SEALED_FILE]
    return [f"{i:06d}.chunk" for i in range(chunks)]


def _refer(contents: backup_copy.CopyContents, copy: Path, layout: StateLayout, keys: dict[str, bytes]) -> Snapshot:
    blobs = [
        (f"media/blobs/{sha[:2]}/{sha}", layout.media / "blobs" / sha[:2] / sha, sha) for sha in contents.blob_sha256s
    ]
    files: list[tuple[str, Path]] = []
    done = contents.finished_analyses
    for analysis in done:
        files += _analysis_files(layout.analyses / analysis.id, f"analyses/{analysis.id}")
    for patient in sorted({analysis.patient_id for analysis in done}):
        track = layout.analyses / "patients" / patient / "track.json"
        if track.is_file():  # the per-visit registrations beside it are a cache, rebuilt on the next analysis
            files.append((f"analyses/patients/{patient}/track.json", track))
    outbox = [
        (f"outbox/{b.bundle_id}/{name}", layout.outbox / b.bundle_id / name)
        for b in contents.queued_bundles
        for name in _outbox_files(layout.outbox / b.bundle_id, b.chunks)
    ]
    site_id = None
    if PUBLIC_FILE in keys:
        try:
            site_id = json.loads(keys[PUBLIC_FILE]).get("site_id")
        except (ValueError, AttributeError):
            site_id = None
    return Snapshot(
        database=copy,
        audit_head=contents.audit_head,
        migrations=contents.migrations,
        site_id=site_id,
        keys=keys,
        blobs=blobs,
        files=files,
        outbox=outbox,
    )


def _analysis_files(folder: Path, prefix: str) -> list[tuple[str, Path]]:
    """A finished analysis's files, without the scratch the retention clean-up removes anyway."""
    if not folder.is_dir():
        return []
    found = []
    for path in sorted(folder.rglob("*")):
        rel = path.relative_to(folder).as_posix()
        if (
            path.is_file()
            and not path.name.endswith(".tmp")
            and not any(rel == part or rel.startswith(part + "/") for part in SCRATCH)
        ):
            found.append((f"{prefix}/{rel}", path))
    return found
