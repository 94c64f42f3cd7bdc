"""Users, roles, sessions and paired devices."""

from __future__ import annotations

import enum
from typing import Annotated

import msgspec

from schemas.base import Frozen, Message, ShortText, Timestamp

Username = Annotated[str, msgspec.Meta(pattern=r"\A[a-z0-9][a-z0-9._-]{1,63}\Z")]
Password = Annotated[str, msgspec.Meta(min_length=10, max_length=256)]


class Role(enum.StrEnum):
    clinician = "clinician"
    nurse = "nurse"
    admin = "admin"
    consultant = "consultant"


class UserCreate(Message):
    username: Username
    password: Password
    role: Role
    display_name: ShortText = ""


class User(Frozen):
    id: str
    username: str
    role: Role
    display_name: str
    active: bool
    created_at: Timestamp
    must_change_password: bool = False
    """Set by an administrator's password reset: until the user changes it, a session may only change the
    password (POST /api/v1/auth/password), read /auth/me and log out."""


class LoginRequest(Message):
    username: Annotated[str, msgspec.Meta(max_length=64)]
    password: Annotated[str, msgspec.Meta(max_length=256)]


class PasswordChange(Message):
    """POST /api/v1/auth/password: a user changes their own password."""

    current_password: Annotated[str, msgspec.Meta(max_length=256)]
    new_password: Password


class PasswordReset(Message):
    """POST /api/v1/admin/users/{id}/reset-password: a temporary password the user must change at next sign-in."""

    password: Password


class Session(Frozen):
    access_token: str
    """Send as "Authorization: Bearer <token>"."""
    expires_at: Timestamp
    user: User
    device_id: str | None


class PairingCodeRequest(Message):
    device_name: ShortText
    """What the phone will be called in the device list, e.g. "ward 2 phone"."""


class PairingCode(Frozen):
    code: str
    device_name: str
    expires_at: Timestamp


class PairRequest(Message):
    code: Annotated[str, msgspec.Meta(max_length=32)]
    device_fingerprint: ShortText = ""
    """Phone-side identifier (hardware or install ID) recorded with the device."""


class DeviceToken(Frozen):
    device_id: str
    device_token: str
    """Send as "X-Device-Token" when logging in from this phone; shown once."""


class Device(Frozen):
    id: str
    name: str
    fingerprint: str
    paired_at: Timestamp
    paired_by: str
    revoked_at: Timestamp | None
    last_seen_at: Timestamp | None


class Identity(Frozen):
    """Who the current session belongs to."""

    user_id: str
    username: str
    role: Role
    device_id: str | None
    must_change_password: bool = False
    """True after an administrator's reset: change the password (POST /api/v1/auth/password) before anything else."""


class Health(Frozen):
    """GET /health: whether the gateway is up and its database answers."""

    status: str
    version: str


# Rows as base/storage/accounts.py hands them out ------------------------------------------------------------


class StoredUser(Frozen):
    """A user as stored: the account and its password's Argon2id hash (never sent out)."""

    user: User
    password_hash: str


class StoredSession(Frozen):
    """A login session joined with its user and its phone (if any): what a bearer token is checked against."""

    user_id: str
    username: str
    role: Role
    active: bool
    must_change_password: bool
    device_id: str | None
    expires_at: Timestamp
    revoked_at: Timestamp | None
    device_revoked_at: Timestamp | None
    """When the session's phone was unpaired; None for a session without a phone or with a paired one."""


class StoredPairingCode(Frozen):
    """A pairing code as stored: only its hash, who asked for it and for which phone."""

    code_hash: str
    device_name: str
    created_by: str
    created_at: Timestamp
    expires_at: Timestamp
    used_at: Timestamp | None


class ThrottleCount(Frozen):
    """The login throttle's count of recent unsuccessful attempts for one key (an account or a client address)."""

    key: str
    failures: int
    last_attempt_at: Timestamp
    locked_until: Timestamp | None
