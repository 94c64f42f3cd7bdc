"""Audit trail entries: hash-chained so that editing or removing a past entry is detectable."""

from __future__ import annotations

from schemas.base import Frozen


class AuditEntry(Frozen):
    seq: int
    at: str
    """UTC time, ISO 8601, as hashed."""
    user_id: str | None
    device_id: str | None
    action: str
    kind: str | None
    record_id: str | None
    before_version: int | None
    after_version: int | None
    detail: str
    content_hash: str | None
    """SHA-256 of the record version written (data, withdrawn flag, reason), when the entry records one."""
    prev_hash: str
    hash: str


class AuditVerification(Frozen):
    ok: bool
    entries: int
    first_broken_seq: int | None
    reason: str


class AuditHead(Frozen):
    """The newest entry of a chain: its sequence number and hash. Whoever holds a copy can later tell whether the
    chain was cut back or rewritten up to it."""

    seq: int
    hash: str


class AuditAnchor(Frozen):
    """A burn center's signed statement that a clinic's chain had reached `head` (kind "audit-anchor").

    The clinic keeps the newest one in its keys folder, outside the database, and `audit verify` checks the chain
    against it; the center keeps every one it signed, per site."""

    site_id: str
    center_id: str
    head: AuditHead
    anchored_at: str
    """The center's UTC time, ISO 8601."""
