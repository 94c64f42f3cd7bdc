"""The burn center's PostgreSQL database, with the same methods as base.storage.database.Database.

Connections come from a pool (psycopg_pool) in autocommit mode. A statement outside a transaction borrows a
connection for itself; write() and read() hold one for their block, and every statement of the thread inside the
block runs on it. Results are fetched whole before a connection goes back to the pool, so callers keep the
sqlite3 shape (execute, fetchone, fetchall, iteration, rowcount).

Writers queue on one transaction-level advisory lock, as SQLite's BEGIN IMMEDIATE makes them queue: the audit
chain reads its last entry and appends the next in one transaction, which must not interleave with another
worker's. Write transactions are short (files are written before them), so this costs little; readers never wait.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import psycopg
import psycopg_pool
from psycopg import errors as pg_errors

from base.storage.database import Database
from base.storage.dialect import postgres_ddl, pyformat, row_factory, shown
from schemas.base import iso, utcnow
from schemas.errors import DuplicateRow, StorageError

_WRITE_LOCK = 0x6275726E  # "burn": one number every burnedge worker of this database takes before it writes
_MIGRATE_LOCK = 0x6D696772  # "migr"
MIGRATIONS_TABLE = "burnedge_migrations"
Step = Callable[[Any], None]


class Result:
    """A statement's rows, fetched; read like a sqlite3 cursor."""

    def __init__(self, rows: list, rowcount: int):
        self.rows = rows
        self.rowcount = rowcount

    def fetchone(self):
        return self.rows[0] if self.rows else None

    def fetchall(self) -> list:
        return self.rows

    def __iter__(self):
        return iter(self.rows)


class Handle:
    """What connection(), write() and read() give a thread: statements with `?` placeholders."""

    def __init__(self, db: PostgresDatabase):
        self._db = db
        self.held: psycopg.Connection | None = None

    def execute(self, sql: str, params: Sequence | None = None) -> Result:
        if self.held is not None:
            return self._run(self.held, sql, params)
        with self._db.borrow() as conn:
            return self._run(conn, sql, params)

    def executemany(self, sql: str, rows: Iterable[Sequence]) -> None:
        rows = list(rows)
        if not rows:
            return
        if self.held is not None:
            self.held.cursor().executemany(pyformat(sql), rows)
            return
        with self._db.borrow() as conn, conn.transaction():
            conn.cursor().executemany(pyformat(sql), rows)

    @staticmethod
    def _run(conn: psycopg.Connection, sql: str, params: Sequence | None) -> Result:
        with _translated():
            cur = conn.execute(pyformat(sql), params or None)
            return Result(cur.fetchall() if cur.description else [], cur.rowcount)


class PostgresDatabase:
    """A PostgreSQL database shared by the center's threads and by other center workers."""

    def __init__(self, url: str, *, max_connections: int = 10, timeout_s: float = 30.0):
        self.url = url
        self.name = shown(url)
        self._pool = psycopg_pool.ConnectionPool(
            url,
            min_size=1,
            max_size=max_connections,
            timeout=timeout_s,
            kwargs={"autocommit": True, "row_factory": row_factory},
            name="burnedge",
            open=False,
        )
        self._local = threading.local()
        try:
            self._pool.open(wait=True, timeout=timeout_s)
        except psycopg_pool.PoolTimeout as exc:
            self._pool.close()
            raise StorageError(f"cannot reach the PostgreSQL database {self.name} within {timeout_s:g} s") from exc

    @contextmanager
    def borrow(self) -> Iterator[psycopg.Connection]:
        try:
            with self._pool.connection() as conn:
                yield conn
        except psycopg_pool.PoolTimeout as exc:
            raise StorageError(f"no free connection to {self.name}: the center is overloaded, try again") from exc
        except psycopg.OperationalError as exc:
            raise StorageError(f"the PostgreSQL database {self.name} is unreachable: {exc}") from exc

    def connection(self) -> Handle:
        handle = getattr(self._local, "handle", None)
        if handle is None:
            handle = self._local.handle = Handle(self)
        return handle

    @contextmanager
    def _held(self, *, write: bool) -> Iterator[Handle]:
        handle = self.connection()
        if handle.held is not None:
            raise RuntimeError("a transaction is open on this thread already (use savepoint for a nested one)")
        with self.borrow() as conn:
            handle.held = conn
            try:
                with _translated(), conn.transaction():
                    if write:
                        conn.execute("SELECT pg_advisory_xact_lock(%s)", (_WRITE_LOCK,))
                    else:
                        conn.execute("SET TRANSACTION ISOLATION LEVEL REPEATABLE READ READ ONLY")
                    yield handle
            finally:
                handle.held = None

    @contextmanager
    def write(self) -> Iterator[Handle]:
        """One atomic write transaction: all of it is stored, or none of it."""
        with self._held(write=True) as handle:
            yield handle

    @contextmanager
    def read(self) -> Iterator[Handle]:
        """A consistent snapshot for several SELECTs."""
        with self._held(write=False) as handle:
            yield handle

    @contextmanager
    def savepoint(self, handle: Handle, name: str = "item") -> Iterator[None]:
        """A nested transaction inside write(): undoes only its own changes on error."""
        if handle.held is None:
            raise RuntimeError("savepoint() belongs inside write()")
        with _translated(), handle.held.transaction(savepoint_name=name):
            yield

    def migrate(self, set_name: str, steps: Sequence[Step]) -> list[str]:
        """Apply the steps of `set_name` not applied yet, each in its own transaction with its record; the names
        applied. Workers starting together queue on a lock, so each step runs once."""
        applied: list[str] = []
        with self.borrow() as conn, _translated():
            with conn.transaction():
                conn.execute("SELECT pg_advisory_xact_lock(%s)", (_MIGRATE_LOCK,))
                conn.execute(
                    f"CREATE TABLE IF NOT EXISTS {MIGRATIONS_TABLE} (migration_set TEXT NOT NULL, name TEXT NOT NULL,"
                    " applied_at TEXT NOT NULL, PRIMARY KEY (migration_set, name))"
                )
            for step in steps:
                with conn.transaction():
                    conn.execute("SELECT pg_advisory_xact_lock(%s)", (_MIGRATE_LOCK,))
                    done = conn.execute(
                        f"SELECT 1 FROM {MIGRATIONS_TABLE} WHERE migration_set = %s AND name = %s",
                        (set_name, step.__name__),
                    ).fetchone()
                    if done:
                        continue
                    step(_Ddl(conn))
                    conn.execute(
                        f"INSERT INTO {MIGRATIONS_TABLE} (migration_set, name, applied_at) VALUES (%s, %s, %s)",
                        (set_name, step.__name__, iso(utcnow())),
                    )
                    applied.append(step.__name__)
        return applied

    def check_readable(self) -> None:
        """Raises unless the database answers and holds a migrated schema (the health endpoint's probe)."""
        self.connection().execute(f"SELECT 1 FROM {MIGRATIONS_TABLE} LIMIT 1").fetchall()

    def close(self) -> None:
        self._pool.close()


class _Ddl:
    """What a migration step is given: execute() of SQLite-typed DDL, run in PostgreSQL's types."""

    def __init__(self, conn: psycopg.Connection):
        self._conn = conn

    def execute(self, sql: str, params: Sequence | None = None) -> None:
        self._conn.execute(pyformat(postgres_ddl(sql)), params or None)


@contextmanager
def _translated() -> Iterator[None]:
    """psycopg's errors as the project's: a refused duplicate key, or storage trouble."""
    try:
        yield
    except pg_errors.UniqueViolation as exc:
        raise DuplicateRow(f"already stored: {exc.diag.message_primary}") from exc
    except psycopg.OperationalError as exc:
        raise StorageError(f"the database could not complete this, nothing was written: {exc}") from exc


AnyDatabase = Database | PostgresDatabase
"""A server's database: a SQLite file (the gateway, a one-worker center) or PostgreSQL (a center of several)."""
