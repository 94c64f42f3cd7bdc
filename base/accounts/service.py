"""Login sessions, phone pairing and device tokens; users and passwords are in base/accounts/users.py.

Passwords are hashed with Argon2id (argon2-cffi). Session and device tokens are
random 256-bit strings; only their SHA-256 is stored, so a copied database does not
hand out working tokens.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import secrets
import threading

import argon2

from base.accounts.permissions import Principal, require_admin
from base.accounts.throttle import LoginThrottle
from base.accounts.users import UserCare, user_from_row
from base.storage import audit
from base.storage.database import Database
from schemas.accounts import (
    Device,
    DeviceToken,
    PairingCode,
    PairingCodeRequest,
    PairRequest,
    Role,
    Session,
)
from schemas.base import iso, utcnow
from schemas.config import SecurityConfig
from schemas.errors import AuthenticationFailed, NotFound
from schemas.ids import uuid7

_CODE_ALPHABET = "ABCDEFGHJKMNPQRSTVWXYZ23456789"  # no 0/O, 1/I/L: read aloud and typed on a phone


def token_hash(token: str) -> str:
    return hashlib.sha256(token.encode("utf-8")).hexdigest()


class AccountService(UserCare):
    """Logins, sessions, phones; account care (users, passwords) comes from UserCare."""

    def __init__(self, db: Database, config: SecurityConfig):
        self.db = db
        self.config = config
        self.hasher = argon2.PasswordHasher(
            time_cost=config.argon2_time_cost,
            memory_cost=config.argon2_memory_kib,
            parallelism=config.argon2_parallelism,
        )
        self._hashing = threading.BoundedSemaphore(config.argon2_max_concurrent)
        # Verifying against this keeps a login for an unknown user as slow as for a known one.
        self._dummy_hash = self._hash(secrets.token_hex(16))
        self.throttle = LoginThrottle(db, config)

    # login ---------------------------------------------------------------
    def login(self, username: str, password: str, *, client: str, device_token: str | None) -> Session:
        account_key, client_key = f"user:{username.lower()}", f"client:{client}"
        self.throttle.begin_attempt([account_key, client_key])
        row = self.db.connection().execute("SELECT * FROM users WHERE username = ?", (username,)).fetchone()
        if not self._password_ok(row, password):
            with self.db.write() as conn:
                # The typed name is not kept unless it is an account: people type passwords into it.
                audit.append(
                    conn,
                    action="auth.failed",
                    user_id=row["id"] if row else None,
                    device_id=None,
                    detail="wrong password" if row else "unknown username",
                )
            raise AuthenticationFailed("wrong username or password")
        if not row["active"]:
            raise AuthenticationFailed("this account is disabled: ask an administrator")
        if device_token is None and row["role"] in self.config.paired_device_roles:
            raise AuthenticationFailed(f"a {row['role']} logs in from a paired phone here: use the clinic's phone app")
        device_id = self._device_for_token(device_token) if device_token else None
        token = secrets.token_urlsafe(32)
        now = utcnow()
        expires = now + dt.timedelta(seconds=self.config.session_ttl_s)
        rehash = self._hash(password) if self.hasher.check_needs_rehash(row["password_hash"]) else None
        with self.db.write() as conn:
            if rehash:
                conn.execute("UPDATE users SET password_hash = ? WHERE id = ?", (rehash, row["id"]))
            conn.execute(
                "INSERT INTO sessions (token_hash, user_id, device_id, created_at, expires_at) VALUES (?,?,?,?,?)",
                (token_hash(token), row["id"], device_id, iso(now), iso(expires)),
            )
            if device_id:
                conn.execute("UPDATE devices SET last_seen_at = ? WHERE id = ?", (iso(now), device_id))
            self.throttle.succeeded(conn, account_key, [client_key])
            audit.append(conn, action="auth.login", user_id=row["id"], device_id=device_id)
        return Session(access_token=token, expires_at=expires, user=user_from_row(row), device_id=device_id)

    def _hash(self, password: str) -> str:
        with self._hashing:
            return self.hasher.hash(password)

    def _password_ok(self, row, password: str) -> bool:
        try:
            with self._hashing:
                return (
                    self.hasher.verify(row["password_hash"] if row else self._dummy_hash, password) and row is not None
                )
        except (argon2.exceptions.VerificationError, argon2.exceptions.InvalidHashError):
            return False

    def _device_for_token(self, device_token: str) -> str:
        row = (
            self.db.connection()
            .execute("SELECT id, revoked_at FROM devices WHERE token_hash = ?", (token_hash(device_token),))
            .fetchone()
        )
        if row is None:
            raise AuthenticationFailed("unknown device token: pair this phone again")
        if row["revoked_at"]:
            raise AuthenticationFailed("this phone's pairing was revoked: ask an administrator to pair it again")
        return row["id"]

    def authenticate(self, bearer: str) -> Principal:
        """Resolve a session token. Checked on every request, so revocation acts at once."""
        th = token_hash(bearer)
        row = (
            self.db.connection()
            .execute(
                "SELECT s.user_id, s.device_id, s.expires_at, s.revoked_at, u.username, u.role, u.active,"
                " u.must_change_password,"
                " d.revoked_at AS device_revoked_at FROM sessions s JOIN users u ON u.id = s.user_id"
                " LEFT JOIN devices d ON d.id = s.device_id WHERE s.token_hash = ?",
                (th,),
            )
            .fetchone()
        )
        if row is not None and row["device_revoked_at"]:
            raise AuthenticationFailed("this phone's pairing was revoked: ask an administrator to pair it again")
        if row is None or row["revoked_at"] or not row["active"]:
            raise AuthenticationFailed("session unknown or ended: log in again")
        if dt.datetime.fromisoformat(row["expires_at"]) <= utcnow():
            raise AuthenticationFailed("session expired: log in again")
        return Principal(
            row["user_id"],
            row["username"],
            Role(row["role"]),
            row["device_id"],
            th,
            must_change_password=bool(row["must_change_password"]),
        )

    def logout(self, principal: Principal) -> None:
        with self.db.write() as conn:
            conn.execute(
                "UPDATE sessions SET revoked_at = ? WHERE token_hash = ?", (iso(utcnow()), principal.session_hash)
            )
            audit.append(conn, action="auth.logout", user_id=principal.user_id, device_id=principal.device_id)

    # pairing and devices -------------------------------------------------------
    def create_pairing_code(self, actor: Principal, body: PairingCodeRequest) -> PairingCode:
        require_admin(actor, "manage_devices")
        raw = "".join(secrets.choice(_CODE_ALPHABET) for _ in range(8))
        code = f"{raw[:4]}-{raw[4:]}"
        now = utcnow()
        expires = now + dt.timedelta(seconds=self.config.pairing_code_ttl_s)
        with self.db.write() as conn:
            conn.execute(
                "INSERT INTO pairing_codes (code_hash, device_name, created_by, created_at, expires_at) VALUES (?,?,?,?,?)",
                (token_hash(raw), body.device_name, actor.user_id, iso(now), iso(expires)),
            )
            audit.append(
                conn,
                action="device.pairing_code",
                user_id=actor.user_id,
                device_id=actor.device_id,
                detail=body.device_name,
            )
        return PairingCode(code=code, device_name=body.device_name, expires_at=expires)

    def pair(self, body: PairRequest, *, client: str) -> DeviceToken:
        self.throttle.begin_attempt([f"pair:{client}"])
        normalized = body.code.upper().replace("-", "").replace(" ", "")
        now = utcnow()
        with self.db.write() as conn:
            row = conn.execute("SELECT * FROM pairing_codes WHERE code_hash = ?", (token_hash(normalized),)).fetchone()
            usable = row is not None and not row["used_at"] and dt.datetime.fromisoformat(row["expires_at"]) > now
            if usable:
                token = secrets.token_urlsafe(32)
                device_id = uuid7()
                conn.execute("UPDATE pairing_codes SET used_at = ? WHERE code_hash = ?", (iso(now), row["code_hash"]))
                conn.execute(
                    "INSERT INTO devices (id, name, fingerprint, token_hash, paired_at, paired_by) VALUES (?,?,?,?,?,?)",
                    (
                        device_id,
                        row["device_name"],
                        body.device_fingerprint,
                        token_hash(token),
                        iso(now),
                        row["created_by"],
                    ),
                )
                audit.append(
                    conn,
                    action="device.pair",
                    user_id=row["created_by"],
                    device_id=device_id,
                    kind="device",
                    record_id=device_id,
                    detail=row["device_name"],
                )
        if not usable:
            # One answer for wrong, used and expired codes: nothing to learn about which codes exist.
            raise AuthenticationFailed("pairing code not valid (wrong, already used or expired): ask for a new one")
        return DeviceToken(device_id=device_id, device_token=token)

    def list_devices(self, actor: Principal) -> list[Device]:
        require_admin(actor, "manage_devices")
        rows = self.db.connection().execute("SELECT * FROM devices ORDER BY paired_at")
        return [_device(r) for r in rows]

    def revoke_device(self, actor: Principal, device_id: str) -> Device:
        require_admin(actor, "manage_devices")
        now = iso(utcnow())
        with self.db.write() as conn:
            row = conn.execute("SELECT * FROM devices WHERE id = ?", (device_id,)).fetchone()
            if row is None:
                raise NotFound(f"no device with id {device_id}")
            if not row["revoked_at"]:
                conn.execute("UPDATE devices SET revoked_at = ? WHERE id = ?", (now, device_id))
                conn.execute(
                    "UPDATE sessions SET revoked_at = ? WHERE device_id = ? AND revoked_at IS NULL", (now, device_id)
                )
                audit.append(
                    conn,
                    action="device.revoke",
                    user_id=actor.user_id,
                    device_id=actor.device_id,
                    kind="device",
                    record_id=device_id,
                    detail=row["name"],
                )
            return _device(conn.execute("SELECT * FROM devices WHERE id = ?", (device_id,)).fetchone())


def _device(row) -> Device:
    def t(value):
        return dt.datetime.fromisoformat(value) if value else None

    return Device(
        id=row["id"],
        name=row["name"],
        fingerprint=row["fingerprint"],
        paired_at=t(row["paired_at"]),
        paired_by=row["paired_by"],
        revoked_at=t(row["revoked_at"]),
        last_seen_at=t(row["last_seen_at"]),
    )
