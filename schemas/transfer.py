"""Store-and-forward between a clinic's gateway and the burn center: keys, case bundles and the wire messages.

What relays see is a `SignedEnvelope` around a `TransferManifest` (ids, sizes, chunk hashes, the sealed key) and
the encrypted chunks. Everything about the patient is inside the encrypted bundle: its `BundleManifest`, the
record, the analyses and their files.
"""

from __future__ import annotations

import enum
from typing import Annotated

import msgspec

from schemas.audit import AuditHead
from schemas.base import Frozen, Id, LongText, ShortText

SITE_ID_PATTERN = r"\A[a-z0-9][a-z0-9-]{1,62}\Z"
SiteId = Annotated[
    str,
    msgspec.Meta(
        pattern=SITE_ID_PATTERN,
        description="A site's name on the wire: lower-case letters, digits and dashes, e.g. 'clinic-kasese'.",
    ),
]
Sha256 = Annotated[str, msgspec.Meta(pattern=r"\A[0-9a-f]{64}\Z")]
PROTOCOL = 1
"""Version of the wire messages below; a receiver rejects others with the reason."""


class SiteRole(enum.StrEnum):
    clinic = "clinic"
    center = "center"


class SiteIdentity(Frozen):
    """A site's public keys, as exchanged at enrolment (`burnedge keys export`) and kept by its peers."""

    site_id: SiteId
    role: SiteRole
    name: ShortText
    """What people call the site, e.g. 'Kasese field clinic'."""
    sign_key: str
    """Ed25519 verify key, hex: checks the site's signatures."""
    box_key: str
    """X25519 public key, hex: what is sent to the site is sealed to it."""
    box_key_signature: str
    """The box key signed with the sign key, hex: binds the two keys to one holder."""


class Peer(Frozen):
    """An enrolled peer as a site keeps it."""

    identity: SiteIdentity
    fingerprint: str
    """Compare this with the peer's own `burnedge keys show` over the phone before trusting it."""
    enrolled_at: str
    enrolled_by: ShortText
    revoked_at: str | None = None
    revoke_reason: str | None = None


class SignedEnvelope(Frozen):
    """A message signed by its sender's Ed25519 key: `body` is the msgpack of the message named by `kind`."""

    protocol: int
    kind: str
    signer: SiteId
    body: bytes
    signature: bytes


class Urgency(enum.StrEnum):
    """How soon a consultant should look, from the clinic's referral assessment (decision support)."""

    immediate = "immediate"
    """An immediate-consultation criterion (consider transfer) is met."""
    consult = "consult"
    """A consultation criterion is met."""
    undetermined = "undetermined"
    """The record lacks data the referral criteria need."""
    routine = "routine"
    """No referral criterion is met."""


URGENCY_ORDER = {Urgency.immediate: 0, Urgency.consult: 1, Urgency.undetermined: 2, Urgency.routine: 3}


class BundlePart(Frozen):
    name: str
    """Path inside the bundle, e.g. 'record.json', 'analyses/<job>/mesh/surface.glb'."""
    media_type: str
    sha256: Sha256
    size: int


class CaseWound(Frozen):
    """One of the patient's wounds as the case summary shows it, with what this encounter measured of it."""

    wound_id: str
    """The wound record's id (its record is in the bundle's wounds.json, its healing in healing.json)."""
    label: str
    """The name people use for it ("left forearm")."""
    regions: list[str]
    """The Lund-Browder regions it covers (empty for a wound the upgrade made, until a clinician sets them)."""
    state: str
    """open, healing, healed, grafted or closed_other."""
    analyses: int
    """This encounter's finished 3D analyses of the wound."""
    area_cm2: float | None
    """Burn area of the latest of those with a metric scale; None when none has one."""


class CaseSummary(Frozen):
    """What a consultant's case list shows before opening a case."""

    urgency: Urgency
    urgency_reasons: list[str]
    """The referral criteria met, as their text."""
    encounter_mode: str
    age_years: float | None
    tbsa_percent: float | None
    analyses: int
    """Finished 3D analyses included."""
    area_cm2: float | None
    """Burn area of the latest analysis with a metric scale; None when none has one."""
    analysis_confidence: str | None
    """Confidence level ('high', 'moderate', 'low') of that latest scaled analysis."""
    wounds: list[CaseWound] = []
    """The patient's live wounds, oldest first; empty for a patient with none (and in bundles sent before wounds
    were kept). An analysis without a wound counts for the patient's only wound."""
    patient_name: str = ""
    """How the clinic names the patient (the name, an unknown patient's temporary label or the record number), for
    the consultant's case list; empty in bundles from clinics before it was sent."""


class BundleManifest(Frozen):
    """The encrypted bundle's own table of contents: every part with its sha256 and size."""

    bundle_id: Id
    site_id: SiteId
    patient_id: Id
    encounter_id: Id
    version: int
    """1 for an encounter's first bundle; an amended encounter sends the next version."""
    supersedes: Id | None
    created_at: str
    created_by: ShortText
    summary: CaseSummary
    parts: list[BundlePart]


class ChunkRef(Frozen):
    sha256: Sha256
    """Of the encrypted chunk: chunks are content-addressed."""
    size: int


class TransferManifest(Frozen):
    """The signed, unencrypted announcement of a bundle: no patient data, only what delivery needs."""

    protocol: int
    bundle_id: Id
    site_id: SiteId
    center_id: SiteId
    encounter_id: Id
    version: int
    created_at: str
    sealed_key: bytes
    """The bundle's fresh symmetric key, sealed to the center's X25519 key."""
    plain_size: int
    chunks: list[ChunkRef]


class AnnounceReply(Frozen):
    status: str
    """'send' (send the chunks not in `held`), or 'stored' (already stored: `receipt` is the proof)."""
    held: list[int] = []
    receipt: SignedEnvelope | None = None


class Receipt(Frozen):
    """The center's signed word that it reassembled, verified and stored a bundle."""

    center_id: SiteId
    site_id: SiteId
    bundle_id: Id
    version: int
    manifest_sha256: Sha256
    stored_at: str
    duplicate: bool
    """True when the bundle had been stored before (a re-send); nothing new was stored."""


class CommitReply(Frozen):
    status: str
    """'stored' with `receipt`, or 'missing' with the chunk indexes still needed."""
    missing: list[int] = []
    receipt: SignedEnvelope | None = None


class MailRequest(Frozen):
    """A clinic asking for its messages; `after` acknowledges every message up to that sequence number."""

    site_id: SiteId
    center_id: SiteId
    after: int
    sent_at: str


class AnchorRequest(Frozen):
    """A clinic asking the center to anchor its audit chain's head (kind "anchor-request").

    `previous` is the clinic's own entry at the sequence number the center anchored last, so the center can tell
    that the chain still runs through it; None on the first anchor, or when the clinic does not know that number
    (the center then answers 'need' with it)."""

    site_id: SiteId
    center_id: SiteId
    head: AuditHead
    previous: AuditHead | None
    sent_at: str


class AnchorReply(Frozen):
    status: str
    """'anchored' (`anchor` is the center's signed AuditAnchor) or 'need' (send again with `previous` at
    `need_seq`)."""
    anchor: SignedEnvelope | None = None
    need_seq: int | None = None


class SealedMessage(Frozen):
    """A message to one site: encrypted with a fresh key sealed to the recipient, then signed by the sender."""

    seq: int
    recipient: SiteId
    sealed_key: bytes
    ciphertext: bytes


class Recommendation(enum.StrEnum):
    transfer = "transfer"
    """Transfer to the burn center."""
    manage_locally = "manage_locally"
    """Manage at the clinic, with the advice below."""
    telemedicine_follow_up = "telemedicine_follow_up"
    """Send further pictures or a follow-up visit for review."""
    more_information = "more_information"
    """The consultant needs more information to advise."""


class ConsultationNote(Frozen):
    """A burn-center consultant's advice on a case: decision support for the treating clinician."""

    note_id: Id
    encounter_id: Id
    patient_id: Id
    bundle_id: Id
    """The bundle (version of the case) the consultant read."""
    bundle_version: int
    center_id: SiteId
    consultant: ShortText
    """The consultant's name, as shown to the clinician."""
    consultant_user_id: str
    written_at: str
    recommendation: Recommendation
    advice: LongText
    notice: str = (
        "Advice from a remote consultant, who has not examined the patient: decision support for the "
        "treating clinician, who decides."
    )


class Consultation(Frozen):
    """The `consultation` record at the clinic: a note as received, with when and from which center."""

    encounter_id: Id
    note: ConsultationNote
    received_at: str
    signed_by: SiteId


class OutboxState(enum.StrEnum):
    queued = "queued"
    """Waiting for a link to the center (or part-way sent: see sent_chunks)."""
    delivered = "delivered"
    """The center confirmed it reassembled, verified and stored the bundle (its signed receipt is kept)."""


class OutboxEntry(Frozen):
    """A case bundle at the clinic, on its way to the burn center or delivered."""

    bundle_id: Id
    encounter_id: Id
    version: int
    center_id: SiteId
    state: OutboxState
    chunks: int
    sent_chunks: int
    """Chunks the center has acknowledged so far."""
    bytes: int
    """Encrypted size."""
    created_at: str
    created_by: ShortText
    attempts: int
    """Rounds that tried to send it and failed (no link, center busy, a rejection)."""
    last_error: str | None
    delivered_at: str | None
    unchanged: bool = False
    """True when a send was asked for but nothing had changed since this bundle: no new version was made."""


class OutboxBundle(Frozen):
    """An outbox row as the clinic keeps it: the entry people see, and what only the queue and the sender read."""

    entry: OutboxEntry
    content_digest: str
    """Over the parts' names and hashes: queueing the same content again makes no new version."""
    envelope: bytes
    """The msgpack of the signed TransferManifest, announced as stored on every try."""


class SyncStatus(Frozen):
    """The clinic's link to the burn center, for the IT person and the clinician's "sent" badge."""

    enabled: bool
    site_id: str | None
    center_id: str | None
    queued: int
    delivered: int
    last_round_at: str | None
    last_success_at: str | None
    last_error: str | None
    next_round_at: str | None
    failures_in_a_row: int
    audit_anchored_seq: int | None = None
    """The newest entry of this gateway's audit chain that the burn center has anchored (signed and kept)."""
    audit_anchored_at: str | None = None
    audit_anchor_problem: str | None = None
    """Set when the center refused to anchor the chain: it no longer runs through the entry anchored before
    (entries removed, or the database replaced by an older copy). Run `burnedge audit verify`."""
    center_endpoints: list[str] = []
    """Where the rounds reach the center: the Burn center page's setting, else the configuration file's."""
    link_set_by: str | None = None
    """Who set the link on the Burn center page (None: it comes from the configuration file)."""
    link_set_at: str | None = None


class SyncRoundState(Frozen):
    """The clinic's sync rounds as the gateway keeps them between rounds (the sync_state table): what the status
    reports and what the backoff waits on. A value never written is None (failures 0)."""

    last_round_at: str | None = None
    last_success_at: str | None = None
    last_error: str | None = None
    next_round_at: str | None = None
    """When the backoff lets the next round run."""
    failures: int = 0
    """Rounds failed in a row since the last success."""
    audit_anchor_problem: str | None = None


ZENOH_ENDPOINT_PATTERN = r"\A(tcp|tls|quic|udp|ws)/[^\s/]+:\d{1,5}\Z"
ZenohEndpoint = Annotated[
    str, msgspec.Meta(pattern=ZENOH_ENDPOINT_PATTERN, examples=["tcp/203.0.113.5:7447", "tls/center.example.org:7447"])
]


class LinkSettings(Frozen):
    """The link to the burn center as the clinic's administrator set it on the Burn center page. Once set it
    takes the place of [sync] enabled and center_endpoints, and the next round uses it: no restart."""

    enabled: bool
    """Send queued cases and fetch the center's advice."""
    center_endpoints: list[ZenohEndpoint]
    """Where the burn center listens, as its administrator's page shows it, e.g. "tcp/203.0.113.5:7447"."""
    set_by: ShortText
    set_at: str
