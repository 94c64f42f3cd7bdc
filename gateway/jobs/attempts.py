"""Every try of an analysis job and how it ended (the `analysis_attempts` table), so that a crash the queue
recovered from is never silent: the API, the demo's progress line and the worker log say which try ended how,
in which stage, and what its process last wrote.

Called inside the queue's transactions: a try's row opens when a worker claims the job and closes with the
state change that ends the try.
"""

from __future__ import annotations

import sqlite3

from schemas.jobs import AttemptOutcome, JobAttempt

LOG_TAIL_CHARS = 16000
"""How much of the end of a try's log is kept with it."""


def begin(conn: sqlite3.Connection, job_id: str, attempt: int, at: str, resumed_from: str) -> None:
    seq = conn.execute("SELECT coalesce(max(seq), 0) + 1 FROM analysis_attempts WHERE job_id = ?", (job_id,))
    conn.execute(
        "INSERT INTO analysis_attempts (job_id, seq, attempt, started_at, resumed_from, outcome) VALUES (?,?,?,?,?,?)",
        (job_id, seq.fetchone()[0], attempt, at, resumed_from, AttemptOutcome.running.value),
    )


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
    conn.execute(
        "UPDATE analysis_attempts SET outcome = ?, ended_at = ?, stage = ?, reason = ?, exit = ?, log_tail = ?"
        " WHERE job_id = ? AND outcome = 'running'",
        (outcome.value, at, stage, reason, exit, log_tail[-LOG_TAIL_CHARS:], job_id),
    )


def history(conn: sqlite3.Connection, job_id: str) -> list[JobAttempt]:
    rows = conn.execute("SELECT * FROM analysis_attempts WHERE job_id = ? ORDER BY seq", (job_id,)).fetchall()
    return [
        JobAttempt(
            attempt=r["attempt"],
            started_at=r["started_at"],
            outcome=AttemptOutcome(r["outcome"]),
            ended_at=r["ended_at"],
            stage=r["stage"],
            resumed_from=r["resumed_from"],
            exit=r["exit"],
            reason=r["reason"],
            log_tail=r["log_tail"],
        )
        for r in rows
    ]


def ended(attempt: int, reason: str, stage: str) -> str:
    """'try 1 ended by SIGSEGV in the mesh stage'."""
    return f"try {attempt} {reason}" + (f" in the {stage} stage" if stage else "")


def summaries(conn: sqlite3.Connection, job_id: str) -> list[str]:
    """One line per try that crashed, hung or lost its worker, for the job's `history` (read on every poll of the
    job: the logs are left out)."""
    tries = conn.execute(
        "SELECT attempt, outcome, stage, reason, resumed_from FROM analysis_attempts WHERE job_id = ? ORDER BY seq",
        (job_id,),
    ).fetchall()
    lines = []
    for k, a in enumerate(tries):
        if a["outcome"] not in (AttemptOutcome.crashed, AttemptOutcome.hung, AttemptOutcome.lost):
            continue
        line = ended(a["attempt"], a["reason"], a["stage"])
        if k + 1 < len(tries):
            line += f"; retried from {tries[k + 1]['resumed_from'] or 'the start'}"
        lines.append(line)
    return lines
