"""The durable analysis queue: rows in the gateway's SQLite file, moved between states in short transactions.

Workers claim the most urgent queued job (emergency before consultation, then oldest) and hold it under a
lease they renew. A job whose lease ran out (its worker was killed, the power went) is queued again, with
backoff, until `max_attempts`; then it fails with the reason. Every state change checks the lease owner, so
a worker that lost its job can never overwrite what the next one does.
"""

from __future__ import annotations

import datetime as dt
import random
import sqlite3
from dataclasses import dataclass

import msgspec

from gateway.jobs import attempts
from gateway.storage.database import Database
from schemas.base import iso, utcnow
from schemas.config import JobsConfig
from schemas.errors import Conflict, NotFound
from schemas.jobs import FINISHED, AnalysisJob, AttemptOutcome, CaptureTime, JobAttempt, JobState

WORKER_DIED = "lost its worker (killed, power cut or out of memory)"
_ENDED = {
    JobState.done: AttemptOutcome.done,
    JobState.failed: AttemptOutcome.failed,
    JobState.cancelled: AttemptOutcome.cancelled,
}


@dataclass(frozen=True)
class Claim:
    """A job a worker now holds."""

    job_id: str
    owner: str
    attempt: int


@dataclass(frozen=True)
class Beat:
    """What a heartbeat learned: whether the worker still holds the job, whether it was cancelled, and whether it
    is finished (its process may still be bringing the patient's healing track up to date)."""

    owned: bool
    cancel: bool
    finished: bool = False


def _now() -> dt.datetime:
    return utcnow()


def _at(t: dt.datetime) -> str:
    return iso(t)


class JobQueue:
    def __init__(self, db: Database, conf: JobsConfig):
        self.db, self.conf = db, conf

    def backoff_s(self, attempts: int) -> float:
        """Wait before the next try after `attempts` tries: base x 2^(n-1), capped, plus up to 20 % jitter."""
        delay = min(self.conf.retry_max_s, self.conf.retry_base_s * 2 ** max(attempts - 1, 0))
        return delay * (1 + random.uniform(0, 0.2))

    # workers ---------------------------------------------------------------------------------------------
    def claim(self, owner: str) -> Claim | None:
        """Take the most urgent job that may run now; None when there is none."""
        now = _now()
        with self.db.write() as conn:
            self._reap(conn, now)
            row = conn.execute(
                "SELECT id, attempts, stage FROM analysis_jobs WHERE state = 'queued' AND next_attempt_at <= ?"
                " ORDER BY priority, created_at LIMIT 1",
                (_at(now),),
            ).fetchone()
            if row is None:
                return None
            conn.execute(
                "UPDATE analysis_jobs SET state = 'running', lease_owner = ?, lease_expires_at = ?,"
                " attempts = attempts + 1, started_at = COALESCE(started_at, ?), message = ? WHERE id = ?",
                (
                    owner,
                    _at(now + dt.timedelta(seconds=self.conf.lease_s)),
                    _at(now),
                    f"starting (try {row['attempts'] + 1} of {self.conf.max_attempts})",
                    row["id"],
                ),
            )
            attempts.begin(conn, row["id"], row["attempts"] + 1, _at(now), row["stage"])
            return Claim(row["id"], owner, row["attempts"] + 1)

    def heartbeat(self, claim: Claim) -> Beat:
        with self.db.write() as conn:
            row = conn.execute(
                "SELECT state, lease_owner, cancel_requested FROM analysis_jobs WHERE id = ?", (claim.job_id,)
            ).fetchone()
            if row is None or row["state"] != JobState.running or row["lease_owner"] != claim.owner:
                # Only a stored result lets the process run on (it updates the healing track); a job cancelled or
                # failed by the reaper meanwhile must be stopped.
                return Beat(owned=False, cancel=False, finished=row is not None and row["state"] == JobState.done)
            expires = _at(_now() + dt.timedelta(seconds=self.conf.lease_s))
            conn.execute("UPDATE analysis_jobs SET lease_expires_at = ? WHERE id = ?", (expires, claim.job_id))
            return Beat(owned=True, cancel=bool(row["cancel_requested"]))

    def progress(self, claim: Claim, stage: str, fraction: float, message: str) -> bool:
        with self.db.write() as conn:
            cur = conn.execute(
                "UPDATE analysis_jobs SET stage = ?, fraction = ?, message = ? WHERE id = ? AND state = 'running'"
                " AND lease_owner = ?",
                (stage, round(min(max(fraction, 0.0), 1.0), 4), message, claim.job_id, claim.owner),
            )
            return cur.rowcount == 1

    def finish_in(
        self,
        conn: sqlite3.Connection,
        claim: Claim,
        state: JobState,
        *,
        result_status: str | None,
        error: str | None,
        message: str,
    ) -> bool:
        """Close the job inside the caller's transaction; False (nothing written) if the worker lost it."""
        cur = conn.execute(
            "UPDATE analysis_jobs SET state = ?, result_status = ?, error = ?, message = ?, finished_at = ?,"
            " fraction = CASE WHEN ? = 'done' THEN 1.0 ELSE fraction END, lease_owner = NULL, lease_expires_at = NULL"
            " WHERE id = ? AND state = 'running' AND lease_owner = ? RETURNING stage",
            (state.value, result_status, error, message, _at(_now()), state.value, claim.job_id, claim.owner),
        )
        closed = cur.fetchone()
        if closed is None:
            return False
        attempts.end(conn, claim.job_id, _ENDED[state], _at(_now()), stage=closed["stage"], reason=error or message)
        return True

    def finish(self, claim: Claim, state: JobState, *, error: str | None, message: str) -> bool:
        with self.db.write() as conn:
            return self.finish_in(conn, claim, state, result_status=None, error=error, message=message)

    def retry_or_fail(
        self,
        claim: Claim,
        reason: str,
        *,
        outcome: AttemptOutcome = AttemptOutcome.crashed,
        exit: str = "",
        log_tail: str = "",
    ) -> JobState:
        """After a crash of this try: queue it again with backoff, or fail it when the tries are used up.
        `reason` completes 'try 2 ...', e.g. 'ended by SIGSEGV'."""
        with self.db.write() as conn:
            row = conn.execute(
                "SELECT attempts, max_attempts, cancel_requested, stage FROM analysis_jobs WHERE id = ?"
                " AND state = 'running' AND lease_owner = ?",
                (claim.job_id, claim.owner),
            ).fetchone()
            if row is None:
                return JobState.running  # lost meanwhile: its new holder decides
            return self._after_try(conn, claim.job_id, row, reason, _now(), outcome, exit, log_tail)

    def _after_try(
        self,
        conn,
        job_id: str,
        row,
        reason: str,
        now: dt.datetime,
        outcome: AttemptOutcome = AttemptOutcome.lost,
        exit: str = "",
        log_tail: str = "",
    ) -> JobState:
        stage = row["stage"]
        ended = attempts.ended(row["attempts"], reason, stage)
        attempts.end(conn, job_id, outcome, _at(now), stage=stage, reason=reason, exit=exit, log_tail=log_tail)
        if row["cancel_requested"]:
            state, error, when, message = JobState.cancelled, None, now, "cancelled"
        elif row["attempts"] >= row["max_attempts"]:
            state, when, message = JobState.failed, now, "failed"
            error = (
                f"the analysis failed {row['attempts']} times; the last time: {ended}. The pictures are kept: "
                f"ask your IT contact to look at the gateway's log and /api/v1/analyses/{job_id}/attempts"
            )
        else:
            state, error = JobState.queued, ended
            when = now + dt.timedelta(seconds=self.backoff_s(row["attempts"]))
            message = f"{ended}; retrying from {stage or 'the start'}"
        conn.execute(
            "UPDATE analysis_jobs SET state = ?, error = ?, next_attempt_at = ?, lease_owner = NULL,"
            " lease_expires_at = NULL, finished_at = ?, message = ? WHERE id = ?",
            (state.value, error, _at(when), _at(now) if state in FINISHED else None, message, job_id),
        )
        return state

    def release(self, claim: Claim) -> None:
        """Hand a job back unfinished because its worker is stopping: queued at once, the try not counted."""
        with self.db.write() as conn:
            row = conn.execute(
                "UPDATE analysis_jobs SET state = CASE WHEN cancel_requested THEN 'cancelled' ELSE 'queued' END,"
                " attempts = max(attempts - 1, 0), next_attempt_at = ?, lease_owner = NULL, lease_expires_at = NULL,"
                " message = CASE WHEN cancel_requested THEN 'cancelled' ELSE 'waiting: the worker was stopped' END,"
                " finished_at = CASE WHEN cancel_requested THEN ? END WHERE id = ? AND state = 'running'"
                " AND lease_owner = ? RETURNING stage",
                (_at(_now()), _at(_now()), claim.job_id, claim.owner),
            ).fetchone()
            if row is not None:  # still this worker's try (a lost lease's try is closed by whoever took it over)
                attempts.end(
                    conn,
                    claim.job_id,
                    AttemptOutcome.handed_back,
                    _at(_now()),
                    stage=row["stage"],
                    reason="was handed back: its worker was stopping",
                )

    # the gateway ---------------------------------------------------------------------------------------------
    def reap(self) -> int:
        """Queue again (or fail) the running jobs whose lease ran out; returns how many."""
        with self.db.write() as conn:
            return self._reap(conn, _now())

    def _reap(self, conn, now: dt.datetime) -> int:
        rows = conn.execute(
            "SELECT id, attempts, max_attempts, cancel_requested, stage FROM analysis_jobs WHERE state = 'running'"
            " AND lease_expires_at < ?",
            (_at(now),),
        ).fetchall()
        for row in rows:
            self._after_try(conn, row["id"], row, WORKER_DIED, now)
        return len(rows)

    def cancel(self, job_id: str) -> JobState:
        """A queued job is cancelled at once; a running one when its worker next beats (a few seconds)."""
        with self.db.write() as conn:
            row = conn.execute("SELECT state FROM analysis_jobs WHERE id = ?", (job_id,)).fetchone()
            if row is None:
                raise NotFound(f"no analysis {job_id}")
            state = JobState(row["state"])
            if state in FINISHED:
                if state is JobState.cancelled:
                    return state
                raise Conflict(f"the analysis is already {state.value}; nothing to cancel")
            if state is JobState.queued:
                conn.execute(
                    "UPDATE analysis_jobs SET state = 'cancelled', cancel_requested = 1, finished_at = ?,"
                    " message = 'cancelled' WHERE id = ?",
                    (_at(_now()), job_id),
                )
                return JobState.cancelled
            conn.execute(
                "UPDATE analysis_jobs SET cancel_requested = 1, message = 'cancelling' WHERE id = ?", (job_id,)
            )
            return JobState.running

    # reads ---------------------------------------------------------------------------------------------------
    def get(self, job_id: str) -> AnalysisJob:
        with self.db.read() as conn:
            row = conn.execute("SELECT * FROM analysis_jobs WHERE id = ?", (job_id,)).fetchone()
            if row is None:
                raise NotFound(f"no analysis {job_id}")
            return job_from_row(row, _position(conn, row), attempts.summaries(conn, job_id))

    def for_encounter(self, encounter_id: str) -> list[AnalysisJob]:
        with self.db.read() as conn:
            rows = conn.execute(
                "SELECT * FROM analysis_jobs WHERE encounter_id = ? ORDER BY created_at", (encounter_id,)
            ).fetchall()
            return [job_from_row(r, _position(conn, r), attempts.summaries(conn, r["id"])) for r in rows]

    def attempt_history(self, job_id: str) -> list[JobAttempt]:
        """Every try of the job, oldest first."""
        with self.db.read() as conn:
            if conn.execute("SELECT 1 FROM analysis_jobs WHERE id = ?", (job_id,)).fetchone() is None:
                raise NotFound(f"no analysis {job_id}")
            return attempts.history(conn, job_id)

    def live_states(self) -> dict[str, int]:
        rows = self.db.connection().execute("SELECT state, count(*) AS n FROM analysis_jobs GROUP BY state")
        return {r["state"]: r["n"] for r in rows}


def _position(conn, row) -> int | None:
    if row["state"] != JobState.queued:
        return None
    ahead = conn.execute(
        "SELECT count(*) FROM analysis_jobs WHERE state = 'queued' AND (priority < ? OR (priority = ? AND"
        " created_at < ?))",
        (row["priority"], row["priority"], row["created_at"]),
    ).fetchone()[0]
    return ahead + 1


def job_from_row(row, position: int | None = None, history: list[str] | None = None) -> AnalysisJob:
    state = JobState(row["state"])
    return AnalysisJob(
        id=row["id"],
        encounter_id=row["encounter_id"],
        patient_id=row["patient_id"],
        state=state,
        priority=row["priority"],
        stage=row["stage"],
        fraction=row["fraction"],
        message=row["message"],
        attempts=row["attempts"],
        max_attempts=row["max_attempts"],
        next_attempt_at=row["next_attempt_at"] if state is JobState.queued else None,
        error=row["error"],
        cancel_requested=bool(row["cancel_requested"]),
        pictures=row["pictures"],
        created_at=row["created_at"],
        created_by=row["created_by"],
        started_at=row["started_at"],
        finished_at=row["finished_at"],
        queue_position=position,
        result_status=row["result_status"],
        history=history or [],
        captured=msgspec.json.decode(row["captured"], type=CaptureTime) if row["captured"] else None,
    )
