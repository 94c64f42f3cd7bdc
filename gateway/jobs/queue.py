"""The durable analysis queue: rows in the gateway's SQLite file (gateway/storage/jobs.py), moved between
states in short transactions.

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
from gateway.storage import jobs
from gateway.storage.database import Database
from schemas.base import iso, utcnow
from schemas.config import JobsConfig
from schemas.errors import Conflict
from schemas.ids import uuid7
from schemas.jobs import FINISHED, AnalysisJob, AttemptOutcome, JobAttempt, JobInputs, JobState, StoredJob
from schemas.patient import EncounterMode

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

    # enqueueing ------------------------------------------------------------------------------------------
    def enqueue(
        self,
        *,
        encounter_id: str,
        patient_id: str,
        input_digest: str,
        inputs: JobInputs,
        mode: EncounterMode,
        created_by: str,
        user_id: str,
        wound_id: str | None = None,
    ) -> tuple[str, bool]:
        """`enqueue_in` in a transaction of its own."""
        with self.db.write() as conn:
            return self.enqueue_in(
                conn,
                encounter_id=encounter_id,
                patient_id=patient_id,
                input_digest=input_digest,
                inputs=inputs,
                mode=mode,
                created_by=created_by,
                user_id=user_id,
                wound_id=wound_id,
            )

    def enqueue_in(
        self,
        conn: sqlite3.Connection,
        *,
        encounter_id: str,
        patient_id: str,
        input_digest: str,
        inputs: JobInputs,
        mode: EncounterMode,
        created_by: str,
        user_id: str,
        wound_id: str | None = None,
    ) -> tuple[str, bool]:
        """Queue an analysis of the encounter inside the caller's transaction, once: while a job of the same
        inputs (`input_digest`) is queued, running or done, that job is the answer. An emergency runs before
        consultations; the job and its inputs' `requested_at` are stamped now.

        Returns the job's id and whether it was created now.
        """
        existing = jobs.find_live(conn, encounter_id, input_digest)
        if existing is not None:
            return existing.id, False
        now = _at(_now())
        job = StoredJob(
            id=uuid7(),
            encounter_id=encounter_id,
            patient_id=patient_id,
            input_digest=input_digest,
            state=JobState.queued,
            priority=0 if mode is EncounterMode.emergency else 1,
            max_attempts=self.conf.max_attempts,
            next_attempt_at=now,
            pictures=len(inputs.pictures),
            created_at=now,
            created_by=created_by,
            user_id=user_id,
            message="waiting for a worker",
            captured=inputs.captured,
            wound_id=wound_id,
        )
        jobs.insert(conn, job, msgspec.structs.replace(inputs, requested_at=now))
        return job.id, True

    # workers ---------------------------------------------------------------------------------------------
    def claim(self, owner: str) -> Claim | None:
        """Take the most urgent job that may run now; None when there is none."""
        now = _now()
        with self.db.write() as conn:
            self._reap(conn, now)
            job = jobs.next_due(conn, _at(now))
            if job is None:
                return None
            attempt = job.attempts + 1
            jobs.start(
                conn,
                job.id,
                owner,
                lease_expires_at=_at(now + dt.timedelta(seconds=self.conf.lease_s)),
                at=_at(now),
                message=f"starting (try {attempt} of {self.conf.max_attempts})",
            )
            attempts.begin(conn, job.id, attempt, _at(now), job.stage)
            return Claim(job.id, owner, attempt)

    def heartbeat(self, claim: Claim) -> Beat:
        with self.db.write() as conn:
            job = jobs.find(conn, claim.job_id)
            if job is None or job.state is not JobState.running or job.lease_owner != claim.owner:
                # Only a stored result lets the process run on (it updates the healing track); a job cancelled or
                # failed by the reaper meanwhile must be stopped.
                return Beat(owned=False, cancel=False, finished=job is not None and job.state is JobState.done)
            jobs.renew_lease(conn, claim.job_id, _at(_now() + dt.timedelta(seconds=self.conf.lease_s)))
            return Beat(owned=True, cancel=job.cancel_requested)

    def progress(self, claim: Claim, stage: str, fraction: float, message: str) -> bool:
        with self.db.write() as conn:
            return jobs.set_progress(
                conn, claim.job_id, claim.owner, stage, round(min(max(fraction, 0.0), 1.0), 4), message
            )

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
        closed = jobs.close(
            conn,
            claim.job_id,
            claim.owner,
            state,
            result_status=result_status,
            error=error,
            message=message,
            at=_at(_now()),
        )
        if closed is None:
            return False
        attempts.end(conn, claim.job_id, _ENDED[state], _at(_now()), stage=closed.stage, reason=error or message)
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
            job = jobs.held(conn, claim.job_id, claim.owner)
            if job is None:
                return JobState.running  # lost meanwhile: its new holder decides
            return self._after_try(conn, job, reason, _now(), outcome, exit, log_tail)

    def _after_try(
        self,
        conn: sqlite3.Connection,
        job: StoredJob,
        reason: str,
        now: dt.datetime,
        outcome: AttemptOutcome = AttemptOutcome.lost,
        exit: str = "",
        log_tail: str = "",
    ) -> JobState:
        stage = job.stage
        ended = attempts.ended(job.attempts, reason, stage)
        attempts.end(conn, job.id, outcome, _at(now), stage=stage, reason=reason, exit=exit, log_tail=log_tail)
        if job.cancel_requested:
            state, error, when, message = JobState.cancelled, None, now, "cancelled"
        elif job.attempts >= job.max_attempts:
            state, when, message = JobState.failed, now, "failed"
            error = (
                f"the analysis failed {job.attempts} times; the last time: {ended}. The pictures are kept: "
                f"ask your IT contact to look at the gateway's log and /api/v1/analyses/{job.id}/attempts"
            )
        else:
            state, error = JobState.queued, ended
            when = now + dt.timedelta(seconds=self.backoff_s(job.attempts))
            message = f"{ended}; retrying from {stage or 'the start'}"
        jobs.settle_try(
            conn,
            job.id,
            state,
            error=error,
            next_attempt_at=_at(when),
            finished_at=_at(now) if state in FINISHED else None,
            message=message,
        )
        return state

    def release(self, claim: Claim) -> None:
        """Hand a job back unfinished because its worker is stopping: queued at once, the try not counted."""
        with self.db.write() as conn:
            job = jobs.hand_back(conn, claim.job_id, claim.owner, _at(_now()))
            if job is not None:  # still this worker's try (a lost lease's try is closed by whoever took it over)
                attempts.end(
                    conn,
                    claim.job_id,
                    AttemptOutcome.handed_back,
                    _at(_now()),
                    stage=job.stage,
                    reason="was handed back: its worker was stopping",
                )

    # the gateway ---------------------------------------------------------------------------------------------
    def reap(self) -> int:
        """Queue again (or fail) the running jobs whose lease ran out; returns how many."""
        with self.db.write() as conn:
            return self._reap(conn, _now())

    def _reap(self, conn: sqlite3.Connection, now: dt.datetime) -> int:
        expired = jobs.lease_expired(conn, _at(now))
        for job in expired:
            self._after_try(conn, job, WORKER_DIED, now)
        return len(expired)

    def cancel(self, job_id: str) -> JobState:
        """A queued job is cancelled at once; a running one when its worker next beats (a few seconds)."""
        with self.db.write() as conn:
            state = jobs.get(conn, job_id).state
            if state in FINISHED:
                if state is JobState.cancelled:
                    return state
                raise Conflict(f"the analysis is already {state.value}; nothing to cancel")
            if state is JobState.queued:
                jobs.cancel_queued(conn, job_id, _at(_now()))
                return JobState.cancelled
            jobs.request_cancel(conn, job_id)
            return JobState.running

    # reads ---------------------------------------------------------------------------------------------------
    def get(self, job_id: str) -> AnalysisJob:
        with self.db.read() as conn:
            job = jobs.get(conn, job_id)
            return analysis_job(job, _position(conn, job), attempts.summaries(conn, job_id))

    def for_encounter(self, encounter_id: str) -> list[AnalysisJob]:
        with self.db.read() as conn:
            return [
                analysis_job(j, _position(conn, j), attempts.summaries(conn, j.id))
                for j in jobs.for_encounter(conn, encounter_id)
            ]

    def attempt_history(self, job_id: str) -> list[JobAttempt]:
        """Every try of the job, oldest first."""
        with self.db.read() as conn:
            jobs.get(conn, job_id)
            return attempts.history(conn, job_id)

    def live_states(self) -> dict[str, int]:
        return jobs.count_by_state(self.db.connection())


def _position(conn: sqlite3.Connection, job: StoredJob) -> int | None:
    if job.state is not JobState.queued:
        return None
    return jobs.queued_ahead(conn, job) + 1


def analysis_job(job: StoredJob, position: int | None = None, history: list[str] | None = None) -> AnalysisJob:
    """What the API shows of a stored job: a retry's time only while it waits, its place in the queue and how its
    earlier tries ended."""
    return AnalysisJob(
        id=job.id,
        encounter_id=job.encounter_id,
        patient_id=job.patient_id,
        state=job.state,
        priority=job.priority,
        stage=job.stage,
        fraction=job.fraction,
        message=job.message,
        attempts=job.attempts,
        max_attempts=job.max_attempts,
        next_attempt_at=job.next_attempt_at if job.state is JobState.queued else None,
        error=job.error,
        cancel_requested=job.cancel_requested,
        pictures=job.pictures,
        created_at=job.created_at,
        created_by=job.created_by,
        started_at=job.started_at,
        finished_at=job.finished_at,
        queue_position=position,
        result_status=job.result_status,
        history=history or [],
        captured=job.captured,
        wound_id=job.wound_id,
    )
