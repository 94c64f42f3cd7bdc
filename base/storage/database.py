"""Connections and transactions for a server's single SQLite file (the gateway's or the burn center's).

Each thread gets its own connection (sqlite3 connections must not be shared across
threads), closed when the thread ends: the ASGI server's worker threads come and go.
Writes use BEGIN IMMEDIATE so that two writers queue on the busy timeout instead of
failing half-way through a read-then-write.
"""

from __future__ import annotations

import fcntl
import sqlite3
import threading
import weakref
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import sqlite_utils
from sqlite_utils import Migrations

from schemas.config import GatewayConfig
from schemas.errors import DuplicateRow, StorageError

_DUPLICATE_KEY = ("SQLITE_CONSTRAINT_PRIMARYKEY", "SQLITE_CONSTRAINT_UNIQUE")


class _ThreadConnection:
    """Owns one thread's connection; closing it when the thread's locals are released."""

    def __init__(self, conn: sqlite3.Connection):
        self.conn = conn
        self._finalizer = weakref.finalize(self, conn.close)

    def check_readable(self) -> None:
        """Raises unless the file opens and holds a migrated schema (the health endpoint's probe)."""
        self.connection().execute("SELECT 1 FROM _sqlite_migrations LIMIT 1").fetchall()

    def close(self) -> None:
        self._finalizer()


class Database:
    """A SQLite file shared by the API's threads (and by other processes such as the CLI)."""

    def __init__(self, path: str | Path, *, synchronous: str = "FULL", busy_timeout_ms: int = 10_000):
        self.path = Path(path)
        self.synchronous = synchronous
        self.busy_timeout_ms = busy_timeout_ms
        self._local = threading.local()
        self._open: weakref.WeakSet[_ThreadConnection] = weakref.WeakSet()

    @classmethod
    def from_config(cls, config: GatewayConfig) -> Database:
        return cls(config.database, synchronous=config.sqlite_synchronous, busy_timeout_ms=config.busy_timeout_ms)

    @property
    def open_connections(self) -> int:
        return len(self._open)

    def connection(self) -> sqlite3.Connection:
        holder = getattr(self._local, "holder", None)
        if holder is None:
            holder = _ThreadConnection(self._connect())
            self._local.holder = holder
            self._open.add(holder)
        return holder.conn

    def _connect(self) -> sqlite3.Connection:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            conn = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False)
            conn.row_factory = sqlite3.Row
            conn.execute(f"PRAGMA busy_timeout = {int(self.busy_timeout_ms)}")
            mode = conn.execute("PRAGMA journal_mode = WAL").fetchone()[0]
            if mode.lower() != "wal":
                raise StorageError(f"{self.path}: could not switch the database to WAL mode (got {mode})")
            conn.execute(f"PRAGMA synchronous = {self.synchronous}")
            conn.execute("PRAGMA foreign_keys = ON")
        except sqlite3.DatabaseError as exc:
            raise StorageError(f"cannot open database {self.path}: {exc}") from exc
        return conn

    @contextmanager
    def write(self) -> Iterator[sqlite3.Connection]:
        """One atomic write transaction: all of it is stored, or none of it."""
        conn = self.connection()
        try:
            conn.execute("BEGIN IMMEDIATE")
        except sqlite3.OperationalError as exc:
            raise StorageError(f"database busy, try again: {exc}") from exc
        try:
            yield conn
            conn.execute("COMMIT")
        except BaseException as exc:
            # SQLite may already have rolled back by itself (disk full, I/O error).
            if conn.in_transaction:
                conn.execute("ROLLBACK")
            if getattr(exc, "sqlite_errorname", "") in _DUPLICATE_KEY:
                raise DuplicateRow(f"already stored: {exc}") from exc
            if isinstance(exc, sqlite3.IntegrityError) or not isinstance(exc, sqlite3.DatabaseError):
                raise
            raise StorageError(f"the database could not store this change, nothing was written: {exc}") from exc

    @contextmanager
    def savepoint(self, conn: sqlite3.Connection, name: str = "item") -> Iterator[None]:
        """A nested transaction inside write(): undoes only its own changes on error."""
        conn.execute(f"SAVEPOINT {name}")
        try:
            yield
        except BaseException:
            conn.execute(f"ROLLBACK TO {name}")
            conn.execute(f"RELEASE {name}")
            raise
        else:
            conn.execute(f"RELEASE {name}")

    @contextmanager
    def read(self) -> Iterator[sqlite3.Connection]:
        """A consistent snapshot for several SELECTs."""
        conn = self.connection()
        conn.execute("BEGIN")
        try:
            yield conn
        finally:
            if conn.in_transaction:
                conn.execute("COMMIT")

    def migrate(self, migrations: Migrations) -> list[str]:
        """Apply the pending ones of `migrations` (each server passes its own set); returns the names applied.
        Safe when processes start together."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with open(self.path.with_name(self.path.name + ".migrate-lock"), "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            db = sqlite_utils.Database(self.connection())
            pending = [m.name for m in migrations.pending(db)]
            migrations.apply(db)
        return pending

    def check_readable(self) -> None:
        """Raises unless the file opens and holds a migrated schema (the health endpoint's probe)."""
        self.connection().execute("SELECT 1 FROM _sqlite_migrations LIMIT 1").fetchall()

    def close(self) -> None:
        for holder in list(self._open):
            holder.close()
        self._local = threading.local()
