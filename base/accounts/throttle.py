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

from base.storage import accounts
from base.storage.database import Database
from schemas.accounts import ThrottleCount
from schemas.base import utcnow
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
            counts = {k: accounts.find_throttle_count(conn, k) for k in keys}
            for count in counts.values():
                if count and count.locked_until and count.locked_until > now:
                    wait = math.ceil((count.locked_until - now).total_seconds())
                    raise TooManyAttempts(
                        f"too many failed attempts: wait {wait} s before trying again", retry_after_s=wait
                    )
            for key, count in counts.items():
                self._count(conn, key, count, now)

    def _count(self, conn: sqlite3.Connection, key: str, count: ThrottleCount | None, now: dt.datetime) -> None:
        window = dt.timedelta(seconds=self.config.login_failure_window_s)
        recent = count is not None and count.last_attempt_at + window > now
        failures = count.failures + 1 if recent else 1
        locked_until = None
        over = failures - self.config.login_free_failures
        if over > 0:
            delay = min(self.config.login_max_delay_s, self.config.login_base_delay_s * 2 ** (over - 1))
            locked_until = now + dt.timedelta(seconds=delay)
        accounts.save_throttle_count(conn, key, failures, now, locked_until)

    def succeeded(self, conn: sqlite3.Connection, account_key: str, other_keys: list[str]) -> None:
        """A good login clears the account's count; the address only gets this attempt back,
        so one valid account cannot reset a password spray against others."""
        accounts.forget_throttle_count(conn, account_key)
        accounts.take_back_one_attempt(conn, other_keys, self.config.login_free_failures)
