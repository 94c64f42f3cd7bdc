"""The SQLite store: migrations, WAL, concurrent writers, and what survives a failed write."""

from __future__ import annotations

import gc
import multiprocessing
import threading

import pytest

from base.accounts.permissions import Principal
from base.storage import audit
from gateway.storage.database import Database
from harness.bodies import patient_body
from schemas.accounts import Role
from schemas.errors import StorageError, VersionMismatch
from schemas.ids import uuid7
from schemas.records import RecordKind

CLINICIAN = Principal("u1", "dr.a", Role.clinician, None, "h")


def test_migrations_are_recorded_and_applied_once(tmp_path):
    db = Database(tmp_path / "m.sqlite3")
    first = db.migrate()
    assert first == [
        "m001_records",
        "m002_accounts",
        "m003_audit",
        "m004_uploads_and_assets",
        "m005_video_frames",
        "m006_analysis_jobs",
        "m007_sync",
        "m008_must_change_password",
        "m009_capture_time_and_attempts",
        "m010_wounds",
        "m011_pictures_set_aside",
        "m012_advice_read",
        "m013_pacs_sends",
    ]
    assert db.migrate() == []
    assert db.connection().execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert db.connection().execute("PRAGMA synchronous").fetchone()[0] == 2  # FULL
    db.close()


def test_a_file_that_is_not_a_database_is_a_clear_error(tmp_path):
    bad = tmp_path / "notes.sqlite3"
    bad.write_text("these are not the records you are looking for" * 100)
    with pytest.raises(StorageError, match="cannot open database"):
        Database(bad).migrate()


def test_two_threads_racing_on_the_same_version_one_wins_one_gets_412(services):
    p = patient_body()
    services.records.create(CLINICIAN, RecordKind.patient, p["id"], p)
    barrier = threading.Barrier(2)
    outcomes: list[object] = []

    def edit(weight: float) -> None:
        barrier.wait()
        try:
            services.records.update(CLINICIAN, RecordKind.patient, p["id"], {**p, "weight_kg": weight}, 1)
            outcomes.append("ok")
        except VersionMismatch as exc:
            outcomes.append(exc.current.meta.version)

    threads = [threading.Thread(target=edit, args=(w,)) for w in (71.0, 72.0)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(outcomes, key=str) == [2, "ok"]
    history = services.records.history(CLINICIAN, RecordKind.patient, p["id"])
    assert [h.meta.version for h in history] == [1, 2]


def test_concurrent_writers_keep_the_audit_chain_intact(services):
    def create_many() -> None:
        for _ in range(15):
            body = patient_body(uuid7())
            services.records.create(CLINICIAN, RecordKind.patient, body["id"], body)

    threads = [threading.Thread(target=create_many) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    result = audit.verify(services.db.connection())
    assert result.ok, result.reason
    assert services.db.connection().execute("SELECT COUNT(*) FROM record_heads").fetchone()[0] == 60


def test_an_error_inside_a_write_leaves_nothing_behind(services):
    body = patient_body()
    with pytest.raises(RuntimeError):
        with services.db.write() as conn:
            services.records.create_in(conn, CLINICIAN, RecordKind.patient, body["id"], body)
            raise RuntimeError("power cut in the middle of the transaction")
    conn = services.db.connection()
    assert conn.execute("SELECT COUNT(*) FROM record_versions").fetchone()[0] == 0
    assert conn.execute("SELECT COUNT(*) FROM audit_log WHERE action LIKE 'record.%'").fetchone()[0] == 0


def test_a_threads_connection_is_closed_when_the_thread_ends(tmp_path):
    db = Database(tmp_path / "t.sqlite3")
    db.migrate()

    def touch() -> None:
        db.connection().execute("SELECT 1").fetchone()

    for _ in range(30):
        t = threading.Thread(target=touch)
        t.start()
        t.join()
    gc.collect()
    assert db.open_connections <= 2  # this thread's, and at most one not yet collected
    db.close()
    assert db.open_connections == 0


def _create_patients(db_path: str, count: int) -> None:
    from gateway.records.service import RecordService
    from schemas.config import Config, GatewayConfig

    db = Database(db_path)
    svc = RecordService(db, Config(gateway=GatewayConfig(database=db_path)))
    for _ in range(count):
        body = patient_body(uuid7())
        svc.create(CLINICIAN, RecordKind.patient, body["id"], body)
    db.close()


def test_writers_in_separate_processes_keep_every_write_and_the_chain(tmp_path):
    path = str(tmp_path / "shared.sqlite3")
    Database(path).migrate()
    ctx = multiprocessing.get_context("spawn")
    procs = [ctx.Process(target=_create_patients, args=(path, 20)) for _ in range(3)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(120)
        assert p.exitcode == 0
    db = Database(path)
    assert db.connection().execute("SELECT COUNT(*) FROM record_heads").fetchone()[0] == 60
    assert audit.verify(db.connection()).ok
    db.close()


def _migrate(path: str) -> None:
    Database(path).migrate()


def test_processes_starting_together_on_a_new_database_both_migrate(tmp_path):
    path = str(tmp_path / "fresh.sqlite3")
    ctx = multiprocessing.get_context("spawn")
    procs = [ctx.Process(target=_migrate, args=(path,)) for _ in range(3)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(60)
        assert p.exitcode == 0


def test_audit_verify_detects_an_edited_record_version(services):
    body = patient_body()
    services.records.create(CLINICIAN, RecordKind.patient, body["id"], body)
    conn = services.db.connection()
    conn.execute("UPDATE record_versions SET data = replace(data, '70.0', '50.0') WHERE kind = 'patient'")
    result = audit.verify(conn)
    assert not result.ok and "altered after entry" in result.reason
