"""Slowing down repeated failed logins and pairing attempts, per account and per client address.

Every attempt is counted before the password is checked, in its own write transaction,
so parallel guesses cannot all slip past the check. After `login_free_failures` attempts
that did not succeed, each further one locks the key for base x 2^(n-1) seconds (capped).
A count is forgotten after `login_failure_window_s` without attempts. Kept in SQLite, so
a restart does not reset it.
"""

from __future__ import annotations

import datetime as dt
import math
import sqlite3

from base.storage.database import Database
from schemas.base import iso, utcnow
from schemas.config import SecurityConfig
from schemas.errors import TooManyAttempts


class LoginThrottle:
    def __init__(self, db: Database, config: SecurityConfig):
        self.db = db
        self.config = config

    def begin_attempt(self, keys: list[str]) -> None:
        """Refuse if any key is locked; otherwise count this attempt against every key."""
        now = utcnow()
        with self.db.write() as conn:
            rows = {k: conn.execute("SELECT * FROM login_throttle WHERE key = ?", (k,)).fetchone() for k in keys}
            for row in rows.values():
                if row and row["locked_until"] and dt.datetime.fromisoformat(row["locked_until"]) > now:
                    wait = math.ceil((dt.datetime.fromisoformat(row["locked_until"]) - now).total_seconds())
                    raise TooManyAttempts(
                        f"too many failed attempts: wait {wait} s before trying again", retry_after_s=wait
                    )
            for key, row in rows.items():
                self._count(conn, key, row, now)

    def _count(self, conn: sqlite3.Connection, key: str, row, now: dt.datetime) -> None:
        window = dt.timedelta(seconds=self.config.login_failure_window_s)
        recent = row is not None and dt.datetime.fromisoformat(row["last_attempt_at"]) + window > now
        failures = row["failures"] + 1 if recent else 1
        locked_until = None
        over = failures - self.config.login_free_failures
        if over > 0:
            delay = min(self.config.login_max_delay_s, self.config.login_base_delay_s * 2 ** (over - 1))
            locked_until = iso(now + dt.timedelta(seconds=delay))
        conn.execute(
            "INSERT INTO login_throttle (key, failures, last_attempt_at, locked_until) VALUES (?,?,?,?)"
            " ON CONFLICT (key) DO UPDATE SET failures = excluded.failures,"
            " last_attempt_at = excluded.last_attempt_at, locked_until = excluded.locked_until",
            (key, failures, iso(now), locked_until),
        )

    def succeeded(self, conn: sqlite3.Connection, account_key: str, other_keys: list[str]) -> None:
        """A good login clears the account's count; the address only gets this attempt back,
        so one valid account cannot reset a password spray against others."""
        conn.execute("DELETE FROM login_throttle WHERE key = ?", (account_key,))
        # SET expressions see the old row: the lock goes only if this attempt was what crossed the limit.
        conn.executemany(
            "UPDATE login_throttle SET failures = MAX(failures - 1, 0),"
            " locked_until = CASE WHEN failures - 1 <= ? THEN NULL ELSE locked_until END WHERE key = ?",
            [(self.config.login_free_failures, k) for k in other_keys],
        )
