"""The durable analysis queue on a real SQLite file: order, leases, retries, cancelling, exactly-once finishing."""

from __future__ import annotations

import time

import msgspec
import pytest

from gateway.jobs.queue import Claim, JobQueue
from gateway.storage.database import Database
from schemas.base import iso, utcnow
from schemas.config import JobsConfig
from schemas.errors import Conflict, NotFound
from schemas.ids import uuid7
from schemas.jobs import JobInputs, JobState
from schemas.patient import EncounterMode

FAST = JobsConfig(lease_s=0.6, heartbeat_s=0.2, retry_base_s=0.0, max_attempts=2)


@pytest.fixture
def queue(tmp_path) -> JobQueue:
    db = Database(tmp_path / "q.sqlite3")
    db.migrate()
    yield JobQueue(db, FAST)
    db.close()


def enqueue(queue: JobQueue, priority: int, encounter: str | None = None) -> str:
    """A job queued as the analysis service queues one (the service itself is tested through the API)."""
    job_id, _ = queue.enqueue(
        encounter_id=encounter or uuid7(),
        patient_id="p1",
        input_digest=uuid7(),
        inputs=JobInputs(pictures=[]),
        mode=EncounterMode.emergency if priority == 0 else EncounterMode.consultation,
        created_by="dr",
        user_id="u1",
    )
    time.sleep(0.002)  # distinct created_at
    return job_id


def test_emergencies_run_first_then_the_oldest(queue):
    consult_old = enqueue(queue, 1)
    emergency = enqueue(queue, 0)
    consult_new = enqueue(queue, 1)
    assert queue.get(consult_old).queue_position == 2 and queue.get(emergency).queue_position == 1
    order = [queue.claim("w").job_id for _ in range(3)]
    assert order == [emergency, consult_old, consult_new]
    assert queue.claim("w") is None
    assert queue.get(emergency).state is JobState.running and queue.get(emergency).queue_position is None


def test_a_dead_workers_job_is_queued_again_then_fails_with_the_reason(queue):
    job = enqueue(queue, 1)
    first = queue.claim("worker-a")
    assert first.attempt == 1
    time.sleep(0.7)  # no heartbeat: worker-a died
    second = queue.claim("worker-b")
    assert second is not None and second.job_id == job and second.attempt == 2
    assert queue.heartbeat(first).owned is False  # the dead worker's lease is gone for good
    assert not queue.progress(first, "dense", 0.3, "late") and queue.get(job).stage == ""
    time.sleep(0.7)
    assert queue.reap() == 1
    failed = queue.get(job)
    assert failed.state is JobState.failed and failed.attempts == 2
    assert "failed 2 times" in failed.error and "killed, power cut or out of memory" in failed.error


def test_a_renewed_lease_is_kept(queue):
    enqueue(queue, 1)
    claim = queue.claim("w")
    for _ in range(5):
        time.sleep(0.2)
        assert queue.heartbeat(claim).owned
    assert queue.reap() == 0 and queue.claim("other") is None


def test_a_crash_is_retried_after_a_backoff(tmp_path):
    db = Database(tmp_path / "q.sqlite3")
    db.migrate()
    queue = JobQueue(db, msgspec.structs.replace(FAST, retry_base_s=30.0, max_attempts=3))
    job = enqueue(queue, 1)
    claim = queue.claim("w")
    assert queue.retry_or_fail(claim, "stopped on an unexpected error (boom)") is JobState.queued
    waiting = queue.get(job)
    assert waiting.state is JobState.queued and "boom" in waiting.error
    assert waiting.next_attempt_at > iso(utcnow()) and queue.claim("w") is None  # not before the backoff
    assert 30 <= queue.backoff_s(1) <= 36 and 60 <= queue.backoff_s(2) <= 72 and queue.backoff_s(30) <= 900 * 1.2
    db.close()


def test_finishing_needs_the_lease_so_a_result_is_stored_once(queue):
    job = enqueue(queue, 1)
    stale = queue.claim("a")
    time.sleep(0.7)
    fresh = queue.claim("b")
    with queue.db.write() as conn:
        assert queue.finish_in(conn, stale, JobState.done, result_status="ok", error=None, message="x") is False
    with queue.db.write() as conn:
        assert queue.finish_in(conn, fresh, JobState.done, result_status="ok", error=None, message="finished")
    with queue.db.write() as conn:
        assert queue.finish_in(conn, fresh, JobState.done, result_status="ok", error=None, message="again") is False
    done = queue.get(job)
    assert done.state is JobState.done and done.fraction == 1.0 and done.message == "finished"


def test_cancel_a_queued_job_at_once_and_a_running_one_at_its_next_heartbeat(queue):
    queued, running = enqueue(queue, 1), enqueue(queue, 0)
    claim = queue.claim("w")
    assert claim.job_id == running
    assert queue.cancel(queued) is JobState.cancelled and queue.get(queued).state is JobState.cancelled
    assert queue.claim("w") is None  # a cancelled job is never picked up
    assert queue.cancel(running) is JobState.running
    beat = queue.heartbeat(claim)
    assert beat.owned and beat.cancel
    assert queue.finish(claim, JobState.cancelled, error=None, message="cancelled")
    assert queue.cancel(running) is JobState.cancelled  # cancelling twice is harmless
    with pytest.raises(NotFound):
        queue.cancel(uuid7())


def test_a_finished_job_cannot_be_cancelled(queue):
    enqueue(queue, 1)
    claim = queue.claim("w")
    queue.finish(claim, JobState.failed, error="no", message="failed")
    with pytest.raises(Conflict, match="already failed"):
        queue.cancel(claim.job_id)


def test_a_stopping_worker_hands_its_job_back_without_using_a_try(queue):
    job = enqueue(queue, 1)
    claim = queue.claim("w")
    queue.release(claim)
    back = queue.get(job)
    assert back.state is JobState.queued and back.attempts == 0
    assert queue.claim("w2") == Claim(job, "w2", 1)


def test_retention_keeps_a_finished_analysis_results_and_drops_its_scratch(tmp_path):
    from gateway.jobs.folders import artifacts, clean_up, job_dir
    from schemas.config import Config, GatewayConfig

    config = Config(gateway=GatewayConfig(database=str(tmp_path / "q.sqlite3")), jobs=JobsConfig(retention_days=1.0))
    db = Database.from_config(config.gateway)
    db.migrate()
    queue = JobQueue(db, config.jobs)
    old_done, old_failed, recent = enqueue(queue, 1), enqueue(queue, 1), enqueue(queue, 1)
    for job_id, state in ((old_done, JobState.done), (old_failed, JobState.failed), (recent, JobState.done)):
        claim = queue.claim("w")
        assert claim.job_id == job_id  # same priority: oldest first
        queue.finish(claim, state, error=None, message=state.value)
        folder = job_dir(config, claim.job_id)
        for name in (
            "source/a.jpg",
            "analysis/images/a.jpg",
            "analysis/dense/fused_points.ply",
            "analysis/sfm/database.db",
            "analysis/analysis.json",
            "analysis/surface/burn_surface.glb",
            "analysis/surface/burn_surface.npz",
            "analysis/mesh/surface.ply",
        ):
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            (folder / name).write_bytes(b"x")
    with db.write() as conn:
        conn.execute(
            "UPDATE analysis_jobs SET finished_at = '2000-01-01T00:00:00.000000+00:00' WHERE id IN (?, ?)",
            (old_done, old_failed),
        )
    assert clean_up(db, config) == 2
    kept = job_dir(config, old_done)
    assert not (kept / "source").exists() and not (kept / "analysis/dense").exists()
    assert not (kept / "analysis/sfm/database.db").exists() and not (kept / "analysis/images").exists()
    assert (kept / "analysis/surface/burn_surface.npz").exists() and (kept / "analysis/mesh/surface.ply").exists()
    assert artifacts(config, old_done) == ["analysis.json", "mesh/surface.ply", "surface/burn_surface.glb"]
    assert not job_dir(config, old_failed).exists()
    assert (job_dir(config, recent) / "source/a.jpg").exists()
    assert clean_up(db, config) == 0  # each job is cleaned once
    db.close()


def test_every_try_is_recorded_with_how_it_ended_and_where_the_retry_resumes(queue):
    job = enqueue(queue, 1)
    first = queue.claim("w")
    queue.progress(first, "mesh", 0.62, "meshing the surface")
    state = queue.retry_or_fail(
        first, "ended by SIGSEGV", exit="SIGSEGV", log_tail="Fatal Python error: Segmentation fault"
    )
    waiting = queue.get(job)
    assert state is JobState.queued and waiting.error == "try 1 ended by SIGSEGV in the mesh stage"
    assert waiting.message == "try 1 ended by SIGSEGV in the mesh stage; retrying from mesh"
    second = queue.claim("w")
    with queue.db.write() as conn:
        assert queue.finish_in(conn, second, JobState.done, result_status="ok", error=None, message="finished")
    crashed, done = queue.attempt_history(job)
    assert (crashed.attempt, crashed.outcome, crashed.exit, crashed.stage) == (1, "crashed", "SIGSEGV", "mesh")
    assert "Segmentation fault" in crashed.log_tail and crashed.ended_at is not None
    assert (done.attempt, done.outcome, done.resumed_from) == (2, "done", "mesh")
    assert queue.get(job).history == ["try 1 ended by SIGSEGV in the mesh stage; retried from mesh"]
    with pytest.raises(NotFound):
        queue.attempt_history(uuid7())
