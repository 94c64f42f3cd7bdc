"""Slowing down repeated failed logins and pairing attempts, per account and per client address.

After `login_free_failures` failures in the window, each further failure locks the key
for base x 2^(n-1) seconds (capped). Kept in SQLite so a restart does not reset it.
"""

from __future__ import annotations

import datetime as dt
import math
import sqlite3

from gateway.storage import audit
from gateway.storage.database import Database
from schemas.base import utcnow
from schemas.config import SecurityConfig
from schemas.errors import TooManyAttempts


class LoginThrottle:
    def __init__(self, db: Database, config: SecurityConfig):
        self.db = db
        self.config = config

    def check(self, keys: list[str]) -> None:
        now = utcnow()
        conn = self.db.connection()
        for key in keys:
            row = conn.execute("SELECT locked_until FROM login_throttle WHERE key = ?", (key,)).fetchone()
            if row and row["locked_until"]:
                until = dt.datetime.fromisoformat(row["locked_until"])
                if until > now:
                    wait = math.ceil((until - now).total_seconds())
                    raise TooManyAttempts(
                        f"too many failed attempts: wait {wait} s before trying again", retry_after_s=wait
                    )

    def record_failure(self, keys: list[str], *, user_id: str | None, what: str) -> None:
        now = utcnow()
        window = dt.timedelta(seconds=self.config.login_failure_window_s)
        with self.db.write() as conn:
            for key in keys:
                row = conn.execute("SELECT failures, window_start FROM login_throttle WHERE key = ?", (key,)).fetchone()
                failures = 1
                start = now
                if row and dt.datetime.fromisoformat(row["window_start"]) + window > now:
                    failures = row["failures"] + 1
                    start = dt.datetime.fromisoformat(row["window_start"])
                locked_until = None
                over = failures - self.config.login_free_failures
                if over > 0:
                    delay = min(self.config.login_max_delay_s, self.config.login_base_delay_s * 2 ** (over - 1))
                    locked_until = (now + dt.timedelta(seconds=delay)).isoformat()
                conn.execute(
                    "INSERT INTO login_throttle (key, failures, window_start, locked_until) VALUES (?,?,?,?)"
                    " ON CONFLICT (key) DO UPDATE SET failures = excluded.failures,"
                    " window_start = excluded.window_start, locked_until = excluded.locked_until",
                    (key, failures, start.isoformat(), locked_until),
                )
            audit.append(conn, action="auth.failed", user_id=user_id, device_id=None, detail=what)

    def clear(self, conn: sqlite3.Connection, keys: list[str]) -> None:
        conn.executemany("DELETE FROM login_throttle WHERE key = ?", [(k,) for k in keys])
