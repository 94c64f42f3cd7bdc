"""Rows of the accounts tables: users, sessions, paired devices, pairing codes and the login throttle.

Knows SQL, not the rules: base/accounts decides who may do what and audits it, inside its own write transactions,
and calls these with that transaction's connection. Tokens and codes arrive here as their SHA-256 only.
"""

from __future__ import annotations

import datetime as dt
import sqlite3
from collections.abc import Iterable

from schemas.accounts import (
    Device,
    Role,
    StoredPairingCode,
    StoredSession,
    StoredUser,
    ThrottleCount,
    User,
)
from schemas.base import iso
from schemas.errors import NotFound


def _time(text: str | None) -> dt.datetime | None:
    return dt.datetime.fromisoformat(text) if text else None


# users ---------------------------------------------------------------------------------------------------------
def _stored_user(row: sqlite3.Row) -> StoredUser:
    user = User(
        id=row["id"],
        username=row["username"],
        role=Role(row["role"]),
        display_name=row["display_name"],
        active=bool(row["active"]),
        created_at=dt.datetime.fromisoformat(row["created_at"]),
        must_change_password=bool(row["must_change_password"]),
    )
    return StoredUser(user=user, password_hash=row["password_hash"])


def find_user(conn: sqlite3.Connection, user_id: str) -> StoredUser | None:
    """The user with this id, or None when there is none."""
    row = conn.execute("SELECT * FROM users WHERE id = ?", (user_id,)).fetchone()
    return _stored_user(row) if row else None


def get_user(conn: sqlite3.Connection, user_id: str) -> StoredUser:
    """The user with this id; NotFound when there is none."""
    stored = find_user(conn, user_id)
    if stored is None:
        raise NotFound(f"no user with id {user_id}")
    return stored


def find_user_named(conn: sqlite3.Connection, username: str) -> StoredUser | None:
    """The user with this exact username, or None when there is none."""
    row = conn.execute("SELECT * FROM users WHERE username = ?", (username,)).fetchone()
    return _stored_user(row) if row else None


def username_taken(conn: sqlite3.Connection, username: str) -> bool:
    return conn.execute("SELECT 1 FROM users WHERE username = ?", (username,)).fetchone() is not None


def list_users(conn: sqlite3.Connection) -> list[User]:
    """Every account, by username."""
    return [_stored_user(r).user for r in conn.execute("SELECT * FROM users ORDER BY username")]


def insert_user(
    conn: sqlite3.Connection,
    *,
    user_id: str,
    username: str,
    password_hash: str,
    role: Role,
    display_name: str,
    created_at: dt.datetime,
) -> None:
    """A new, active account."""
    conn.execute(
        "INSERT INTO users (id, username, password_hash, role, display_name, active, created_at)"
        " VALUES (?,?,?,?,?,1,?)",
        (user_id, username, password_hash, role.value, display_name, iso(created_at)),
    )


def other_active_admins(conn: sqlite3.Connection, user_id: str) -> int:
    """How many active administrators there are besides `user_id`."""
    return conn.execute(
        "SELECT COUNT(*) FROM users WHERE role = ? AND active = 1 AND id != ?", (Role.admin.value, user_id)
    ).fetchone()[0]


def set_user_active(conn: sqlite3.Connection, user_id: str, active: bool) -> None:
    conn.execute("UPDATE users SET active = ? WHERE id = ?", (int(active), user_id))


def replace_password_hash(conn: sqlite3.Connection, user_id: str, password_hash: str) -> None:
    """The same password hashed anew (stronger parameters); the must-change flag stays as it is."""
    conn.execute("UPDATE users SET password_hash = ? WHERE id = ?", (password_hash, user_id))


def set_password(conn: sqlite3.Connection, user_id: str, password_hash: str, *, must_change: bool) -> None:
    """A new password; `must_change`: the user must change it at next sign-in."""
    conn.execute(
        "UPDATE users SET password_hash = ?, must_change_password = ? WHERE id = ?",
        (password_hash, int(must_change), user_id),
    )


# sessions ------------------------------------------------------------------------------------------------------
def insert_session(
    conn: sqlite3.Connection,
    *,
    token_hash: str,
    user_id: str,
    device_id: str | None,
    created_at: dt.datetime,
    expires_at: dt.datetime,
) -> None:
    conn.execute(
        "INSERT INTO sessions (token_hash, user_id, device_id, created_at, expires_at) VALUES (?,?,?,?,?)",
        (token_hash, user_id, device_id, iso(created_at), iso(expires_at)),
    )


def find_session(conn: sqlite3.Connection, token_hash: str) -> StoredSession | None:
    """The session with this token hash, with its user and phone, or None when there is none."""
    row = conn.execute(
        "SELECT s.user_id, s.device_id, s.expires_at, s.revoked_at, u.username, u.role, u.active,"
        " u.must_change_password,"
        " d.revoked_at AS device_revoked_at FROM sessions s JOIN users u ON u.id = s.user_id"
        " LEFT JOIN devices d ON d.id = s.device_id WHERE s.token_hash = ?",
        (token_hash,),
    ).fetchone()
    if row is None:
        return None
    return StoredSession(
        user_id=row["user_id"],
        username=row["username"],
        role=Role(row["role"]),
        active=bool(row["active"]),
        must_change_password=bool(row["must_change_password"]),
        device_id=row["device_id"],
        expires_at=dt.datetime.fromisoformat(row["expires_at"]),
        revoked_at=_time(row["revoked_at"]),
        device_revoked_at=_time(row["device_revoked_at"]),
    )


def end_session(conn: sqlite3.Connection, token_hash: str, at: dt.datetime) -> None:
    conn.execute("UPDATE sessions SET revoked_at = ? WHERE token_hash = ?", (iso(at), token_hash))


def end_user_sessions(conn: sqlite3.Connection, user_id: str, at: dt.datetime, *, keep: str | None = None) -> int:
    """End the user's live sessions (all but `keep`, a session's token hash); how many ended."""
    return conn.execute(
        "UPDATE sessions SET revoked_at = ? WHERE user_id = ? AND revoked_at IS NULL AND token_hash IS NOT ?",
        (iso(at), user_id, keep),
    ).rowcount


def end_device_sessions(conn: sqlite3.Connection, device_id: str, at: dt.datetime) -> None:
    """End every live session opened from this phone."""
    conn.execute("UPDATE sessions SET revoked_at = ? WHERE device_id = ? AND revoked_at IS NULL", (iso(at), device_id))


# devices and pairing codes -------------------------------------------------------------------------------------
def _device(row: sqlite3.Row) -> Device:
    return Device(
        id=row["id"],
        name=row["name"],
        fingerprint=row["fingerprint"],
        paired_at=_time(row["paired_at"]),
        paired_by=row["paired_by"],
        revoked_at=_time(row["revoked_at"]),
        last_seen_at=_time(row["last_seen_at"]),
    )


def get_device(conn: sqlite3.Connection, device_id: str) -> Device:
    """The phone with this id; NotFound when there is none."""
    row = conn.execute("SELECT * FROM devices WHERE id = ?", (device_id,)).fetchone()
    if row is None:
        raise NotFound(f"no device with id {device_id}")
    return _device(row)


def find_device_by_token(conn: sqlite3.Connection, token_hash: str) -> Device | None:
    """The phone this device token was given to, or None when it was never given out."""
    row = conn.execute("SELECT * FROM devices WHERE token_hash = ?", (token_hash,)).fetchone()
    return _device(row) if row else None


def list_devices(conn: sqlite3.Connection) -> list[Device]:
    """Every phone ever paired, oldest pairing first."""
    return [_device(r) for r in conn.execute("SELECT * FROM devices ORDER BY paired_at")]


def insert_device(
    conn: sqlite3.Connection,
    *,
    device_id: str,
    name: str,
    fingerprint: str,
    token_hash: str,
    paired_at: dt.datetime,
    paired_by: str,
) -> None:
    conn.execute(
        "INSERT INTO devices (id, name, fingerprint, token_hash, paired_at, paired_by) VALUES (?,?,?,?,?,?)",
        (device_id, name, fingerprint, token_hash, iso(paired_at), paired_by),
    )


def device_seen(conn: sqlite3.Connection, device_id: str, at: dt.datetime) -> None:
    conn.execute("UPDATE devices SET last_seen_at = ? WHERE id = ?", (iso(at), device_id))


def revoke_device(conn: sqlite3.Connection, device_id: str, at: dt.datetime) -> None:
    conn.execute("UPDATE devices SET revoked_at = ? WHERE id = ?", (iso(at), device_id))


def insert_pairing_code(
    conn: sqlite3.Connection,
    *,
    code_hash: str,
    device_name: str,
    created_by: str,
    created_at: dt.datetime,
    expires_at: dt.datetime,
) -> None:
    conn.execute(
        "INSERT INTO pairing_codes (code_hash, device_name, created_by, created_at, expires_at) VALUES (?,?,?,?,?)",
        (code_hash, device_name, created_by, iso(created_at), iso(expires_at)),
    )


def find_pairing_code(conn: sqlite3.Connection, code_hash: str) -> StoredPairingCode | None:
    """The pairing code with this hash, used or not, or None when there is none."""
    row = conn.execute("SELECT * FROM pairing_codes WHERE code_hash = ?", (code_hash,)).fetchone()
    if row is None:
        return None
    return StoredPairingCode(
        code_hash=row["code_hash"],
        device_name=row["device_name"],
        created_by=row["created_by"],
        created_at=dt.datetime.fromisoformat(row["created_at"]),
        expires_at=dt.datetime.fromisoformat(row["expires_at"]),
        used_at=_time(row["used_at"]),
    )


def use_pairing_code(conn: sqlite3.Connection, code_hash: str, at: dt.datetime) -> None:
    conn.execute("UPDATE pairing_codes SET used_at = ? WHERE code_hash = ?", (iso(at), code_hash))


# login throttle ------------------------------------------------------------------------------------------------
def find_throttle_count(conn: sqlite3.Connection, key: str) -> ThrottleCount | None:
    """The key's count of recent attempts, or None when it has none."""
    row = conn.execute("SELECT * FROM login_throttle WHERE key = ?", (key,)).fetchone()
    if row is None:
        return None
    return ThrottleCount(
        key=row["key"],
        failures=row["failures"],
        last_attempt_at=dt.datetime.fromisoformat(row["last_attempt_at"]),
        locked_until=_time(row["locked_until"]),
    )


def save_throttle_count(
    conn: sqlite3.Connection, key: str, failures: int, last_attempt_at: dt.datetime, locked_until: dt.datetime | None
) -> None:
    """Store the key's count, replacing the one it had."""
    conn.execute(
        "INSERT INTO login_throttle (key, failures, last_attempt_at, locked_until) VALUES (?,?,?,?)"
        " ON CONFLICT (key) DO UPDATE SET failures = excluded.failures,"
        " last_attempt_at = excluded.last_attempt_at, locked_until = excluded.locked_until",
        (key, failures, iso(last_attempt_at), iso(locked_until) if locked_until else None),
    )


def forget_throttle_count(conn: sqlite3.Connection, key: str) -> None:
    conn.execute("DELETE FROM login_throttle WHERE key = ?", (key,))


def take_back_one_attempt(conn: sqlite3.Connection, keys: Iterable[str], free_failures: int) -> None:
    """Count one attempt less against each key, unlocking a key whose lock only this attempt had set."""
    # SET expressions see the old row: the lock goes only if this attempt was what crossed the limit.
    conn.executemany(
        "UPDATE login_throttle SET failures = CASE WHEN failures > 0 THEN failures - 1 ELSE 0 END,"
        " locked_until = CASE WHEN failures - 1 <= ? THEN NULL ELSE locked_until END WHERE key = ?",
        [(free_failures, k) for k in keys],
    )
