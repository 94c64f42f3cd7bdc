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
from base.accounts.users import UserCare
from base.storage import accounts, audit
from base.storage.database import Database
from schemas.accounts import (
    Device,
    DeviceToken,
    PairingCode,
    PairingCodeRequest,
    PairRequest,
    Session,
    StoredUser,
)
from schemas.base import utcnow
from schemas.config import SecurityConfig
from schemas.errors import AuthenticationFailed
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
        stored = accounts.find_user_named(self.db.connection(), username)
        if not self._password_ok(stored, password):
            with self.db.write() as conn:
                # The typed name is not kept unless it is an account: people type passwords into it.
                audit.append(
                    conn,
                    action="auth.failed",
                    user_id=stored.user.id if stored else None,
                    device_id=None,
                    detail="wrong password" if stored else "unknown username",
                )
            raise AuthenticationFailed("wrong username or password")
        user = stored.user
        if not user.active:
            raise AuthenticationFailed("this account is disabled: ask an administrator")
        if device_token is None and user.role in self.config.paired_device_roles:
            raise AuthenticationFailed(f"a {user.role} logs in from a paired phone here: use the clinic's phone app")
        device_id = self._device_for_token(device_token) if device_token else None
        token = secrets.token_urlsafe(32)
        now = utcnow()
        expires = now + dt.timedelta(seconds=self.config.session_ttl_s)
        rehash = self._hash(password) if self.hasher.check_needs_rehash(stored.password_hash) else None
        with self.db.write() as conn:
            if rehash:
                accounts.replace_password_hash(conn, user.id, rehash)
            accounts.insert_session(
                conn,
                token_hash=token_hash(token),
                user_id=user.id,
                device_id=device_id,
                created_at=now,
                expires_at=expires,
            )
            if device_id:
                accounts.device_seen(conn, device_id, now)
            self.throttle.succeeded(conn, account_key, [client_key])
            audit.append(conn, action="auth.login", user_id=user.id, device_id=device_id)
        return Session(access_token=token, expires_at=expires, user=user, device_id=device_id)

    def _hash(self, password: str) -> str:
        with self._hashing:
            return self.hasher.hash(password)

    def _password_ok(self, stored: StoredUser | None, password: str) -> bool:
        try:
            with self._hashing:
                return (
                    self.hasher.verify(stored.password_hash if stored else self._dummy_hash, password)
                    and stored is not None
                )
        except (argon2.exceptions.VerificationError, argon2.exceptions.InvalidHashError):
            return False

    def _device_for_token(self, device_token: str) -> str:
        device = accounts.find_device_by_token(self.db.connection(), token_hash(device_token))
        if device is None:
            raise AuthenticationFailed("unknown device token: pair this phone again")
        if device.revoked_at:
            raise AuthenticationFailed("this phone's pairing was revoked: ask an administrator to pair it again")
        return device.id

    def authenticate(self, bearer: str) -> Principal:
        """Resolve a session token. Checked on every request, so revocation acts at once."""
        th = token_hash(bearer)
        session = accounts.find_session(self.db.connection(), th)
        if session is not None and session.device_revoked_at:
            raise AuthenticationFailed("this phone's pairing was revoked: ask an administrator to pair it again")
        if session is None or session.revoked_at or not session.active:
            raise AuthenticationFailed("session unknown or ended: log in again")
        if session.expires_at <= utcnow():
            raise AuthenticationFailed("session expired: log in again")
        return Principal(
            session.user_id,
            session.username,
            session.role,
            session.device_id,
            th,
            must_change_password=session.must_change_password,
        )

    def logout(self, principal: Principal) -> None:
        with self.db.write() as conn:
            accounts.end_session(conn, principal.session_hash, utcnow())
            audit.append(conn, action="auth.logout", user_id=principal.user_id, device_id=principal.device_id)

    # pairing and devices -------------------------------------------------------
    def create_pairing_code(self, actor: Principal, body: PairingCodeRequest) -> PairingCode:
        require_admin(actor, "manage_devices")
        raw = "".join(secrets.choice(_CODE_ALPHABET) for _ in range(8))
        code = f"{raw[:4]}-{raw[4:]}"
        now = utcnow()
        expires = now + dt.timedelta(seconds=self.config.pairing_code_ttl_s)
        with self.db.write() as conn:
            accounts.insert_pairing_code(
                conn,
                code_hash=token_hash(raw),
                device_name=body.device_name,
                created_by=actor.user_id,
                created_at=now,
                expires_at=expires,
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
            code = accounts.find_pairing_code(conn, token_hash(normalized))
            usable = code is not None and not code.used_at and code.expires_at > now
            if usable:
                token = secrets.token_urlsafe(32)
                device_id = uuid7()
                accounts.use_pairing_code(conn, code.code_hash, now)
                accounts.insert_device(
                    conn,
                    device_id=device_id,
                    name=code.device_name,
                    fingerprint=body.device_fingerprint,
                    token_hash=token_hash(token),
                    paired_at=now,
                    paired_by=code.created_by,
                )
                audit.append(
                    conn,
                    action="device.pair",
                    user_id=code.created_by,
                    device_id=device_id,
                    kind="device",
                    record_id=device_id,
                    detail=code.device_name,
                )
        if not usable:
            # One answer for wrong, used and expired codes: nothing to learn about which codes exist.
            raise AuthenticationFailed("pairing code not valid (wrong, already used or expired): ask for a new one")
        return DeviceToken(device_id=device_id, device_token=token)

    def list_devices(self, actor: Principal) -> list[Device]:
        require_admin(actor, "manage_devices")
        return accounts.list_devices(self.db.connection())

    def revoke_device(self, actor: Principal, device_id: str) -> Device:
        require_admin(actor, "manage_devices")
        now = utcnow()
        with self.db.write() as conn:
            device = accounts.get_device(conn, device_id)
            if not device.revoked_at:
                accounts.revoke_device(conn, device_id, now)
                accounts.end_device_sessions(conn, device_id, now)
                audit.append(
                    conn,
                    action="device.revoke",
                    user_id=actor.user_id,
                    device_id=actor.device_id,
                    kind="device",
                    record_id=device_id,
                    detail=device.name,
                )
            return accounts.get_device(conn, device_id)
