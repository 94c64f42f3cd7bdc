"""The `analysis_attempts` table: every try of an analysis job and how it ended (gateway/jobs/attempts.py says
what is written when). Called inside the queue's transactions."""

from __future__ import annotations

import sqlite3

from schemas.jobs import AttemptOutcome, JobAttempt


def begin(conn: sqlite3.Connection, job_id: str, attempt: int, started_at: str, resumed_from: str) -> None:
    """Open the job's next try (numbered after its last row), running."""
    seq = conn.execute("SELECT coalesce(max(seq), 0) + 1 FROM analysis_attempts WHERE job_id = ?", (job_id,))
    conn.execute(
        "INSERT INTO analysis_attempts (job_id, seq, attempt, started_at, resumed_from, outcome) VALUES (?,?,?,?,?,?)",
        (job_id, seq.fetchone()[0], attempt, started_at, resumed_from, AttemptOutcome.running.value),
    )


def end(
    conn: sqlite3.Connection,
    job_id: str,
    outcome: AttemptOutcome,
    ended_at: str,
    *,
    stage: str,
    reason: str,
    exit: str,
    log_tail: str,
) -> None:
    """Close the job's running try, if it has one."""
    conn.execute(
        "UPDATE analysis_attempts SET outcome = ?, ended_at = ?, stage = ?, reason = ?, exit = ?, log_tail = ?"
        " WHERE job_id = ? AND outcome = 'running'",
        (outcome.value, ended_at, stage, reason, exit, log_tail, job_id),
    )


def history(conn: sqlite3.Connection, job_id: str, *, logs: bool = True) -> list[JobAttempt]:
    """The job's tries, oldest first; without `logs` their log tails are left out (read as '')."""
    if logs:
        columns = "attempt, started_at, outcome, ended_at, stage, resumed_from, exit, reason, log_tail"
    else:
        columns = "attempt, started_at, outcome, ended_at, stage, resumed_from, exit, reason, '' AS log_tail"
    rows = conn.execute(f"SELECT {columns} FROM analysis_attempts WHERE job_id = ? ORDER BY seq", (job_id,)).fetchall()
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
