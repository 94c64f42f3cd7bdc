"""Every try of an analysis job and how it ended (the `analysis_attempts` table, gateway/storage/attempts.py),
so that a crash the queue recovered from is never silent: the API, the demo's progress line and the worker log
say which try ended how, in which stage, and what its process last wrote.

Called inside the queue's transactions: a try's row opens when a worker claims the job and closes with the
state change that ends the try.
"""

from __future__ import annotations

import sqlite3

from gateway.storage import attempts as stored
from schemas.jobs import AttemptOutcome, JobAttempt

LOG_TAIL_CHARS = 16000
"""How much of the end of a try's log is kept with it."""


def begin(conn: sqlite3.Connection, job_id: str, attempt: int, at: str, resumed_from: str) -> None:
    stored.begin(conn, job_id, attempt, at, resumed_from)


def end(
    conn: sqlite3.Connection,
    job_id: str,
    outcome: AttemptOutcome,
    at: str,
    *,
    stage: str,
    reason: str = "",
    exit: str = "",
    log_tail: str = "",
) -> None:
    """Close the job's open try (none is open for a job queued before attempts were kept: nothing happens)."""
    stored.end(conn, job_id, outcome, at, stage=stage, reason=reason, exit=exit, log_tail=log_tail[-LOG_TAIL_CHARS:])


def history(conn: sqlite3.Connection, job_id: str) -> list[JobAttempt]:
    return stored.history(conn, job_id)


def ended(attempt: int, reason: str, stage: str) -> str:
    """'try 1 ended by SIGSEGV in the mesh stage'."""
    return f"try {attempt} {reason}" + (f" in the {stage} stage" if stage else "")


def summaries(conn: sqlite3.Connection, job_id: str) -> list[str]:
    """One line per try that crashed, hung or lost its worker, for the job's `history` (read on every poll of the
    job: the logs are left out)."""
    tries = stored.history(conn, job_id, logs=False)
    lines = []
    for k, a in enumerate(tries):
        if a.outcome not in (AttemptOutcome.crashed, AttemptOutcome.hung, AttemptOutcome.lost):
            continue
        line = ended(a.attempt, a.reason, a.stage)
        if k + 1 < len(tries):
            line += f"; retried from {tries[k + 1].resumed_from or 'the start'}"
        lines.append(line)
    return lines
