"""The `analysis_jobs` table: one row per analysis the gateway was asked for, moved between states by the queue
(gateway/jobs/queue.py), which decides what to write; here is only how it is read and written.

Every function takes the caller's connection, so that the queue's checks and changes share one transaction.
Rows come back as schemas.jobs.StoredJob; the `request` column (the job's JobInputs) is read only by `inputs`.
"""

from __future__ import annotations

import sqlite3

import msgspec

from schemas.errors import NotFound
from schemas.jobs import CaptureTime, JobInputs, JobState, StoredJob

_COLUMNS = (
    "id, encounter_id, patient_id, input_digest, state, priority, stage, fraction, message, attempts, max_attempts,"
    " next_attempt_at, lease_owner, lease_expires_at, cancel_requested, error, pictures, result_status, created_at,"
    " created_by, user_id, started_at, finished_at, cleaned_at, captured, wound_id"
)


def _job(row: sqlite3.Row) -> StoredJob:
    return StoredJob(
        id=row["id"],
        encounter_id=row["encounter_id"],
        patient_id=row["patient_id"],
        input_digest=row["input_digest"],
        state=JobState(row["state"]),
        priority=row["priority"],
        stage=row["stage"],
        fraction=row["fraction"],
        message=row["message"],
        attempts=row["attempts"],
        max_attempts=row["max_attempts"],
        next_attempt_at=row["next_attempt_at"],
        lease_owner=row["lease_owner"],
        lease_expires_at=row["lease_expires_at"],
        cancel_requested=bool(row["cancel_requested"]),
        error=row["error"],
        pictures=row["pictures"],
        result_status=row["result_status"],
        created_at=row["created_at"],
        created_by=row["created_by"],
        user_id=row["user_id"],
        started_at=row["started_at"],
        finished_at=row["finished_at"],
        cleaned_at=row["cleaned_at"],
        # NULL for jobs queued before capture times were kept.
        captured=msgspec.json.decode(row["captured"], type=CaptureTime) if row["captured"] else None,
        wound_id=row["wound_id"],
    )


def _one(cur: sqlite3.Cursor) -> StoredJob | None:
    row = cur.fetchone()
    return _job(row) if row is not None else None


# reads ---------------------------------------------------------------------------------------------------------
def find(conn: sqlite3.Connection, job_id: str) -> StoredJob | None:
    """The job, or None when there is no such job."""
    return _one(conn.execute(f"SELECT {_COLUMNS} FROM analysis_jobs WHERE id = ?", (job_id,)))


def get(conn: sqlite3.Connection, job_id: str) -> StoredJob:
    """The job; NotFound when there is none."""
    job = find(conn, job_id)
    if job is None:
        raise NotFound(f"no analysis {job_id}")
    return job


def inputs(conn: sqlite3.Connection, job_id: str) -> JobInputs:
    """What the job analyses (its `request` column); NotFound when there is no such job."""
    row = conn.execute("SELECT request FROM analysis_jobs WHERE id = ?", (job_id,)).fetchone()
    if row is None:
        raise NotFound(f"no analysis {job_id}")
    return msgspec.json.decode(row["request"], type=JobInputs)


def find_live(conn: sqlite3.Connection, encounter_id: str, input_digest: str) -> StoredJob | None:
    """The encounter's queued, running or done job of these inputs (there is at most one), or None."""
    return _one(
        conn.execute(
            f"SELECT {_COLUMNS} FROM analysis_jobs WHERE encounter_id = ? AND input_digest = ? AND state IN"
            " ('queued', 'running', 'done')",
            (encounter_id, input_digest),
        )
    )


def for_encounter(conn: sqlite3.Connection, encounter_id: str) -> list[StoredJob]:
    """The encounter's jobs, oldest first."""
    rows = conn.execute(
        f"SELECT {_COLUMNS} FROM analysis_jobs WHERE encounter_id = ? ORDER BY created_at", (encounter_id,)
    ).fetchall()
    return [_job(r) for r in rows]


def measured(conn: sqlite3.Connection, patient_id: str) -> list[StoredJob]:
    """The patient's jobs that finished with a measurement in mm ('ok'), in the order they finished."""
    rows = conn.execute(
        f"SELECT {_COLUMNS} FROM analysis_jobs WHERE patient_id = ? AND state = 'done' AND result_status = 'ok'"
        " ORDER BY finished_at",
        (patient_id,),
    ).fetchall()
    return [_job(r) for r in rows]


def move_to_patient(conn: sqlite3.Connection, encounter_ids: list[str], patient_id: str) -> int:
    """The encounters' jobs now belong to `patient_id` (two records of one person merged); how many moved."""
    cursor = conn.executemany(
        "UPDATE analysis_jobs SET patient_id = ? WHERE encounter_id = ?", [(patient_id, e) for e in encounter_ids]
    )
    return cursor.rowcount


def next_due(conn: sqlite3.Connection, now: str) -> StoredJob | None:
    """The most urgent queued job whose next try may start at `now` (lower priority first, then oldest), or
    None."""
    return _one(
        conn.execute(
            f"SELECT {_COLUMNS} FROM analysis_jobs WHERE state = 'queued' AND next_attempt_at <= ?"
            " ORDER BY priority, created_at LIMIT 1",
            (now,),
        )
    )


def held(conn: sqlite3.Connection, job_id: str, owner: str) -> StoredJob | None:
    """The job while it runs under `owner`'s lease, else None."""
    return _one(
        conn.execute(
            f"SELECT {_COLUMNS} FROM analysis_jobs WHERE id = ? AND state = 'running' AND lease_owner = ?",
            (job_id, owner),
        )
    )


def lease_expired(conn: sqlite3.Connection, now: str) -> list[StoredJob]:
    """The running jobs whose lease ran out before `now`."""
    rows = conn.execute(
        f"SELECT {_COLUMNS} FROM analysis_jobs WHERE state = 'running' AND lease_expires_at < ?", (now,)
    ).fetchall()
    return [_job(r) for r in rows]


def queued_ahead(conn: sqlite3.Connection, job: StoredJob) -> int:
    """How many queued jobs run before `job` (lower priority, or the same and older)."""
    return conn.execute(
        "SELECT count(*) FROM analysis_jobs WHERE state = 'queued' AND (priority < ? OR (priority = ? AND"
        " created_at < ?))",
        (job.priority, job.priority, job.created_at),
    ).fetchone()[0]


def count_by_state(conn: sqlite3.Connection) -> dict[str, int]:
    """How many jobs are in each state (states without a job are left out)."""
    rows = conn.execute("SELECT state, count(*) AS n FROM analysis_jobs GROUP BY state")
    return {r["state"]: r["n"] for r in rows}


def past_retention(conn: sqlite3.Connection, cutoff: str) -> list[StoredJob]:
    """The finished jobs that finished before `cutoff` and whose work files are not cleaned yet."""
    rows = conn.execute(
        f"SELECT {_COLUMNS} FROM analysis_jobs WHERE state IN ('done', 'failed', 'cancelled') AND finished_at < ?"
        " AND cleaned_at IS NULL",
        (cutoff,),
    ).fetchall()
    return [_job(r) for r in rows]


# writes --------------------------------------------------------------------------------------------------------
def insert(conn: sqlite3.Connection, job: StoredJob, request: JobInputs) -> None:
    """Store a new job (its columns not named here take the table's defaults)."""
    conn.execute(
        "INSERT INTO analysis_jobs (id, encounter_id, patient_id, input_digest, request, state, priority,"
        " max_attempts, next_attempt_at, pictures, created_at, created_by, user_id, message, captured, wound_id)"
        " VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)",
        (
            job.id,
            job.encounter_id,
            job.patient_id,
            job.input_digest,
            msgspec.json.encode(request).decode(),
            job.state.value,
            job.priority,
            job.max_attempts,
            job.next_attempt_at,
            job.pictures,
            job.created_at,
            job.created_by,
            job.user_id,
            job.message,
            msgspec.json.encode(job.captured).decode() if job.captured is not None else None,
            job.wound_id,
        ),
    )


def start(conn: sqlite3.Connection, job_id: str, owner: str, *, lease_expires_at: str, at: str, message: str) -> None:
    """Run the job under `owner`'s lease: one more try counted, its first start kept."""
    conn.execute(
        "UPDATE analysis_jobs SET state = 'running', lease_owner = ?, lease_expires_at = ?,"
        " attempts = attempts + 1, started_at = COALESCE(started_at, ?), message = ? WHERE id = ?",
        (owner, lease_expires_at, at, message, job_id),
    )


def renew_lease(conn: sqlite3.Connection, job_id: str, expires_at: str) -> None:
    conn.execute("UPDATE analysis_jobs SET lease_expires_at = ? WHERE id = ?", (expires_at, job_id))


def set_progress(conn: sqlite3.Connection, job_id: str, owner: str, stage: str, fraction: float, message: str) -> bool:
    """Record where the running job is; False (nothing written) unless it runs under `owner`'s lease."""
    cur = conn.execute(
        "UPDATE analysis_jobs SET stage = ?, fraction = ?, message = ? WHERE id = ? AND state = 'running'"
        " AND lease_owner = ?",
        (stage, fraction, message, job_id, owner),
    )
    return cur.rowcount == 1


def close(
    conn: sqlite3.Connection,
    job_id: str,
    owner: str,
    state: JobState,
    *,
    result_status: str | None,
    error: str | None,
    message: str,
    at: str,
) -> StoredJob | None:
    """End the job running under `owner`'s lease in `state` (a job done is wholly done) and free its lease;
    the job as it is now, or None (nothing written) unless it ran under that lease."""
    return _one(
        conn.execute(
            "UPDATE analysis_jobs SET state = ?, result_status = ?, error = ?, message = ?, finished_at = ?,"
            " fraction = CASE WHEN ? = 'done' THEN 1.0 ELSE fraction END, lease_owner = NULL,"
            f" lease_expires_at = NULL WHERE id = ? AND state = 'running' AND lease_owner = ? RETURNING {_COLUMNS}",
            (state.value, result_status, error, message, at, state.value, job_id, owner),
        )
    )


def settle_try(
    conn: sqlite3.Connection,
    job_id: str,
    state: JobState,
    *,
    error: str | None,
    next_attempt_at: str,
    finished_at: str | None,
    message: str,
) -> None:
    """After a try that did not finish: the job's next state (queued for a retry, failed or cancelled), its
    lease freed."""
    conn.execute(
        "UPDATE analysis_jobs SET state = ?, error = ?, next_attempt_at = ?, lease_owner = NULL,"
        " lease_expires_at = NULL, finished_at = ?, message = ? WHERE id = ?",
        (state.value, error, next_attempt_at, finished_at, message, job_id),
    )


def hand_back(conn: sqlite3.Connection, job_id: str, owner: str, at: str) -> StoredJob | None:
    """The job running under `owner`'s lease queued again at `at`, its try not counted (cancelled instead when
    that was asked for); the job as it is now, or None (nothing written) unless it ran under that lease."""
    return _one(
        conn.execute(
            "UPDATE analysis_jobs SET state = CASE WHEN cancel_requested THEN 'cancelled' ELSE 'queued' END,"
            " attempts = max(attempts - 1, 0), next_attempt_at = ?, lease_owner = NULL, lease_expires_at = NULL,"
            " message = CASE WHEN cancel_requested THEN 'cancelled' ELSE 'waiting: the worker was stopped' END,"
            " finished_at = CASE WHEN cancel_requested THEN ? END WHERE id = ? AND state = 'running'"
            f" AND lease_owner = ? RETURNING {_COLUMNS}",
            (at, at, job_id, owner),
        )
    )


def cancel_queued(conn: sqlite3.Connection, job_id: str, at: str) -> None:
    conn.execute(
        "UPDATE analysis_jobs SET state = 'cancelled', cancel_requested = 1, finished_at = ?,"
        " message = 'cancelled' WHERE id = ?",
        (at, job_id),
    )


def request_cancel(conn: sqlite3.Connection, job_id: str) -> None:
    """Ask the running job's worker to stop it (it sees this at its next heartbeat)."""
    conn.execute("UPDATE analysis_jobs SET cancel_requested = 1, message = 'cancelling' WHERE id = ?", (job_id,))


def mark_cleaned(conn: sqlite3.Connection, job_id: str, at: str) -> None:
    """Record that the retention clean-up removed the job's work files."""
    conn.execute("UPDATE analysis_jobs SET cleaned_at = ? WHERE id = ?", (at, job_id))
