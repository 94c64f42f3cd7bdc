"""The database copy inside a backup: taking it with SQLite's backup API, reading what it refers to, checking it.

Knows SQL and SQLite's file handling, not the backup's format: gateway/backup decides what goes into the archive
and what a restored copy must match.
"""

from __future__ import annotations

import sqlite3
from dataclasses import dataclass
from pathlib import Path

from base.storage import audit
from schemas.audit import AuditHead
from schemas.errors import NotFound, StorageError


@dataclass(frozen=True)
class FinishedAnalysis:
    id: str
    patient_id: str


@dataclass(frozen=True)
class QueuedBundle:
    bundle_id: str
    chunks: int


@dataclass(frozen=True)
class CopyContents:
    """What a database copy refers to outside itself, each list in a stable order; empty for a missing table."""

    migrations: list[str]
    """The burnedge migrations applied, in order."""
    audit_head: AuditHead | None
    """None when the copy has no audit log."""
    blob_sha256s: list[str]
    """Every stored asset's blob, once each."""
    finished_analyses: list[FinishedAnalysis]
    queued_bundles: list[QueuedBundle]
    """Outbox bundles still to send."""


@dataclass(frozen=True)
class CopyCheck:
    integrity: str
    """What PRAGMA quick_check says: "ok", or the first problem."""
    audit_head: AuditHead | None


def copy_database(source: Path, target: Path) -> None:
    """One-step online backup into a single self-contained file (journal mode DELETE, no -wal beside it)."""
    if not source.is_file():
        raise NotFound(f"no database at {source}: check [gateway] database or --db")
    try:
        src = sqlite3.connect(source, timeout=30)
        dst = sqlite3.connect(target)
        try:
            src.backup(dst)  # pages=-1: all pages under one read transaction, the same moment throughout
            dst.execute("PRAGMA journal_mode = DELETE")
            check = dst.execute("PRAGMA quick_check").fetchone()[0]
        finally:
            dst.close()
            src.close()
    except sqlite3.DatabaseError as exc:
        raise StorageError(f"could not copy the database {source}: {exc}") from exc
    if check != "ok":
        raise StorageError(f"the database {source} fails SQLite's integrity check ({check}): repair it first")


def _open(copy: Path) -> sqlite3.Connection:
    conn = sqlite3.connect(copy)
    conn.row_factory = sqlite3.Row
    return conn


def read_contents(copy: Path) -> CopyContents:
    """What the copy refers to: migrations, audit head, blobs, finished analyses and queued outbox bundles."""
    conn = _open(copy)
    try:
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}

        def rows(sql: str, table: str) -> list[sqlite3.Row]:
            return conn.execute(sql).fetchall() if table in tables else []

        migrations = rows(
            "SELECT name FROM _sqlite_migrations WHERE migration_set = 'burnedge' ORDER BY id", "_sqlite_migrations"
        )
        blobs = rows("SELECT DISTINCT sha256 FROM assets ORDER BY sha256", "assets")
        done = rows("SELECT id, patient_id FROM analysis_jobs WHERE state = 'done' ORDER BY id", "analysis_jobs")
        queued = rows("SELECT bundle_id, chunks FROM outbox WHERE state = 'queued' ORDER BY bundle_id", "outbox")
        return CopyContents(
            migrations=[r["name"] for r in migrations],
            audit_head=audit.head(conn) if "audit_log" in tables else None,
            blob_sha256s=[sha for (sha,) in blobs],
            finished_analyses=[FinishedAnalysis(id=r["id"], patient_id=r["patient_id"]) for r in done],
            queued_bundles=[QueuedBundle(bundle_id=r["bundle_id"], chunks=r["chunks"]) for r in queued],
        )
    finally:
        conn.close()


def check_copy(copy: Path) -> CopyCheck:
    """SQLite's quick integrity check of the copy and its last audit entry; StorageError if it does not open as a
    burnedge database (its detail is SQLite's message)."""
    conn = _open(copy)
    try:
        return CopyCheck(integrity=conn.execute("PRAGMA quick_check").fetchone()[0], audit_head=audit.head(conn))
    except sqlite3.DatabaseError as exc:
        raise StorageError(str(exc)) from exc
    finally:
        conn.close()
