"""What the burn center's consultant API returns and accepts, and the rows its storage (center/storage/) hands back."""

from __future__ import annotations

import datetime as dt
import enum
from typing import Annotated

import msgspec

from schemas.audit import AuditHead
from schemas.base import Frozen, LongText, Message
from schemas.transfer import BundleManifest, CaseSummary, ConsultationNote, Recommendation, SiteId, Urgency


class CaseItem(Frozen):
    """One received version of a clinic's case, as the consultant's list shows it."""

    site_id: SiteId
    site_name: str
    bundle_id: str
    encounter_id: str
    patient_id: str
    version: int
    urgency: Urgency
    summary: CaseSummary
    stored_at: str
    superseded_by: str | None
    """A newer version of the same encounter, when one arrived; this one stays readable."""
    notes: int
    """Notes written on this encounter so far."""
    awaiting_advice: bool
    """No note has been written since this version arrived."""


class CaseState(enum.StrEnum):
    """Where a received version stands with the consultants."""

    awaiting = "awaiting"
    """The latest version of its case, and no note has been written since it arrived."""
    advised = "advised"
    """The latest version of its case, with a note written since it arrived."""
    superseded = "superseded"
    """A newer version of the same case has arrived; this one stays readable."""


class CaseFilter(Message):
    """Which cases a page of the consultants' list holds: every filter given must match."""

    urgency: Urgency | None = None
    """Only cases of this urgency."""
    site_id: SiteId | None = None
    """Only cases from this clinic (its site id)."""
    state: CaseState | None = None
    """Only cases in this state. Unset: the latest version of every case (awaiting and advised)."""
    include_superseded: bool = False
    """With no state given, also list the versions a newer one replaced."""
    received_from: dt.date | None = None
    """Only versions the center received on or after this day (UTC)."""
    received_to: dt.date | None = None
    """Only versions the center received on or before this day (UTC)."""
    limit: Annotated[int, msgspec.Meta(ge=1, le=200)] = 50
    """How many cases a page holds."""
    after: Annotated[str, msgspec.Meta(max_length=400)] | None = None
    """The `next_after` of the previous page: the list goes on from there."""


class CasePage(Frozen):
    """One page of the consultants' list: awaiting advice first, then most urgent, then longest waiting (superseded
    versions, when listed, after every current one)."""

    cases: list[CaseItem]
    total: int
    """Cases matching the filter, on every page together (counted up to a limit: see total_capped)."""
    next_after: str | None
    """Pass as `after` for the next page; None on the last page."""
    total_capped: bool = False
    """More cases match than were counted: `total` is the count's limit (10,000), not the number."""


class NoteStatus(Frozen):
    note: ConsultationNote
    delivered_at: str | None
    """When the clinic confirmed it stored the note; None while it is on its way."""


class CaseDetail(Frozen):
    case: CaseItem
    manifest: BundleManifest
    """Every part of the bundle with its sha256 and size (download each from /parts/{name})."""
    versions: list[CaseItem]
    """Every version of this encounter received, newest first."""
    notes: list[NoteStatus]


class NoteRequest(Message):
    recommendation: Recommendation
    advice: LongText = msgspec.field()
    """The advice for the treating clinician, in plain words."""


class RejectionItem(Frozen):
    at: str
    site_id: str | None
    code: str
    reason: str
    key: str


# Rows as center/storage/ hands them out ---------------------------------------------------------------------


class StoredCase(Frozen):
    """A stored bundle as a case, with its manifest."""

    case: CaseItem
    manifest: BundleManifest


class StoredBundle(Frozen):
    """What identifies a stored bundle version."""

    site_id: str
    bundle_id: str
    encounter_id: str
    patient_id: str
    version: int
    manifest_sha256: str
    stored_at: str


class SealedAtRest(Frozen):
    """How a bundle kept as the clinic sealed it is read back."""

    sealed_key: bytes
    """The bundle's key, sealed to the center's X25519 key."""
    chunks: int
    chunk_bytes: int
    """Size of every encrypted chunk but the last, which may be smaller."""
    parts_offset: int
    """Where the bundle's first file starts in its plaintext (after the container's manifest)."""


class StoredPart(Frozen):
    """Where one file of a stored bundle is: inside the clinic's sealed chunks as received, or, for a bundle stored
    before the center kept them sealed, as a plain file named by its sha256."""

    name: str
    media_type: str
    sha256: str
    size: int
    sealed_key: bytes | None
    """The bundle's key as the clinic sealed it to the center's X25519 key; None for a plain file."""
    chunks: int
    """How many chunks the bundle was sent in (part of each chunk's associated data)."""
    chunk_bytes: int
    """Size of every encrypted chunk but the last."""
    plain_offset: int | None
    """Where the file starts in the bundle's plaintext."""


class RefusedBundle(Frozen):
    """A bundle refused whole at its commit: what the clinic is told again if it asks about it again."""

    site_id: str
    bundle_id: str
    code: str
    reason: str
    refused_at: str


class Announcement(Frozen):
    """A transfer a clinic announced and has not committed yet."""

    site_id: str
    bundle_id: str
    envelope: bytes
    """The signed transfer manifest, as the clinic sent it."""
    manifest_sha256: str
    """SHA-256 of the envelope's body: a second announcement of the bundle must carry the same manifest."""
    encounter_id: str
    version: int
    chunks: int
    announced_at: str


class StoredAnchor(Frozen):
    """An audit-chain head of a clinic's that the center signed, and when."""

    head: AuditHead
    anchored_at: str
