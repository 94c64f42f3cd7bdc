"""The clinic's half of audit anchoring: at the end of each sync round the audit chain's head goes to the burn
center, which signs it back if the chain still runs through the head it anchored last. The newest signed anchor
is kept in the keys folder, outside the database, so `burnedge audit verify` can tell a chain cut back or
rewritten at the clinic even with no link; the center tells it at the next round (see docs/security.md).
"""

from __future__ import annotations

import logging
from pathlib import Path

import msgspec

from base.folders import keys_dir
from base.storage import audit
from base.storage.database import Database
from base.storage.durable import replace_atomically
from schemas.audit import AuditAnchor, AuditHead
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.errors import InvalidInput, TransferRejected
from schemas.transfer import AnchorReply, AnchorRequest, SignedEnvelope, SiteIdentity
from sync.keys import SiteKeys, verify_envelope
from sync.wire import request
from sync.zenoh_link import Keys

log = logging.getLogger("burnedge.sync")
ANCHOR_FILE = "audit-anchor.json"


def anchor_path(config: Config) -> Path:
    return keys_dir(config) / ANCHOR_FILE


def load_anchor(path: Path, center: SiteIdentity | None) -> AuditAnchor | None:
    """The newest anchor the center signed, checked against its key when `center` is given; None when there is none
    yet. A file that is not such an anchor is InvalidInput, naming the file."""
    if not path.exists():
        return None
    try:
        envelope = msgspec.json.decode(path.read_bytes(), type=SignedEnvelope)
        if center is None:
            return msgspec.msgpack.decode(envelope.body, type=AuditAnchor)
    except (OSError, msgspec.DecodeError, msgspec.ValidationError) as exc:
        raise InvalidInput(f"the audit anchor {path} is unreadable ({exc}): it was damaged or replaced") from exc
    try:
        return open_anchor(envelope, center)
    except ValueError as exc:
        raise InvalidInput(f"the audit anchor {path} {exc}") from exc


def open_anchor(envelope: SignedEnvelope, center: SiteIdentity) -> AuditAnchor:
    """The anchor in an envelope `center` signed as one; ValueError saying what it is instead."""
    try:
        verify_envelope(envelope, center)
        anchor = msgspec.msgpack.decode(envelope.body, type=AuditAnchor)
    except Exception as exc:  # nacl's BadSignatureError, a malformed signature, or a body that is no anchor
        raise ValueError(f"is not signed by burn center {center.site_id}") from exc
    if envelope.kind != "audit-anchor" or envelope.signer != center.site_id or anchor.center_id != center.site_id:
        raise ValueError(f"is a {envelope.kind!r} from {envelope.signer}, not an audit anchor from {center.site_id}")
    return anchor


def save_anchor(path: Path, envelope: SignedEnvelope) -> None:
    """Replace the kept anchor atomically: a crash leaves the old one or the new one, never half of either."""
    path.parent.mkdir(parents=True, exist_ok=True)
    replace_atomically(path, msgspec.json.encode(envelope))


def exchange(session, link: Keys, db: Database, keys: SiteKeys, center: SiteIdentity, config: Config) -> AuditAnchor:
    """Have the center anchor the chain's head; TransferRejected when it refuses (chain cut back or rewritten)."""
    path = anchor_path(config)
    conn = db.connection()
    head = audit.head(conn)
    if head is None:
        raise InvalidInput("the audit chain is empty: nothing to anchor")
    try:
        kept = load_anchor(path, center)
    except InvalidInput as exc:
        log.warning("%s; asking the center which entry it anchored last", exc.detail)
        kept = None
    previous = _entry(conn, kept.head.seq) if kept else None
    for _ in range(2):
        ask = keys.sign(
            "anchor-request",
            AnchorRequest(
                site_id=keys.site_id, center_id=center.site_id, head=head, previous=previous, sent_at=iso(utcnow())
            ),
        )
        raw = request(session, link.anchor(keys.site_id), msgspec.msgpack.encode(ask), config.sync.query_timeout_s)
        reply = msgspec.msgpack.decode(raw, type=AnchorReply)
        if reply.status == "need" and reply.need_seq is not None:
            previous = _entry(conn, reply.need_seq)
            continue
        if reply.status == "anchored" and reply.anchor is not None:
            anchor = _checked(reply.anchor, center, keys, head)
            save_anchor(path, reply.anchor)
            return anchor
        break
    raise TransferRejected(
        f"the center's answer to the audit anchor was not usable ({reply.status})", code="bad-anchor"
    )


def _entry(conn, seq: int) -> AuditHead:
    # A chain cut back below `seq` has no such entry: an empty hash lets the center say so, with its reason.
    return AuditHead(seq=seq, hash=audit.hash_at(conn, seq) or "")


def _checked(envelope: SignedEnvelope, center: SiteIdentity, keys: SiteKeys, head: AuditHead) -> AuditAnchor:
    try:
        anchor = open_anchor(envelope, center)
    except ValueError as exc:
        raise TransferRejected(f"the center's answer {exc}", code="bad-anchor") from exc
    if anchor.site_id != keys.site_id or anchor.head != head:
        raise TransferRejected("the center anchored something other than this chain's head", code="bad-anchor")
    return anchor
