"""The center's half of audit anchoring: each sync round a clinic sends its audit chain's head, and the center
signs and keeps it, provided the chain still runs through the head it anchored last.

The center cannot read a clinic's chain; it compares hashes. A head with a lower sequence number than the last
anchored one means entries were removed or the clinic's database was replaced by an older copy; the same sequence
number with another hash, or a later head whose entry at the anchored number differs, means the chain was
rewritten. Either is refused with its reason, recorded in `rejections`, and the anchor stays where it was, until
the center's IT person accepts a restore from a backup (`burnedge peers accept-restore SITE --center`).
"""

from __future__ import annotations

from collections.abc import Callable

import msgspec

from base.storage import audit
from base.storage.postgres import AnyDatabase
from center.storage import anchors
from schemas.audit import AuditAnchor, AuditHead
from schemas.base import iso, utcnow
from schemas.central import StoredAnchor
from schemas.errors import TransferRejected
from schemas.transfer import AnchorReply, AnchorRequest, SignedEnvelope, SiteIdentity, SiteRole
from sync import peers
from sync.keys import SiteKeys

Verifier = Callable[[str, bytes, str], tuple[SignedEnvelope, SiteIdentity]]


class AnchorBook:
    def __init__(self, db: AnyDatabase, keys: SiteKeys, verified: Verifier):
        self.db = db
        self.keys = keys
        self.verified = verified

    def anchor(self, site_id: str, payload: bytes) -> AnchorReply:
        envelope, _ = self.verified(site_id, payload, "anchor-request")
        try:
            request = msgspec.msgpack.decode(envelope.body, type=AnchorRequest)
        except (msgspec.DecodeError, msgspec.ValidationError) as exc:
            raise TransferRejected(f"the anchor request is not a valid message ({exc})", code="garbage") from exc
        if request.site_id != site_id or request.center_id != self.keys.site_id:
            raise TransferRejected(
                f"anchor request addressed to {request.center_id} from {request.site_id}", code="misaddressed"
            )
        with self.db.write() as conn:
            last = anchors.latest_anchor(conn, site_id)
            if last is not None:
                if request.previous is None or request.previous.seq != last.head.seq:
                    return AnchorReply(status="need", need_seq=last.head.seq)
                _check_runs_through(site_id, request.head, request.previous, last)
            if last is None or request.head.seq > last.head.seq:
                anchors.insert_anchor(conn, site_id, request.head, iso(utcnow()))
            newest = anchors.latest_anchor(conn, site_id)
        anchor = AuditAnchor(
            site_id=site_id, center_id=self.keys.site_id, head=newest.head, anchored_at=newest.anchored_at
        )
        return AnchorReply(status="anchored", anchor=self.keys.sign("audit-anchor", anchor))


def accept_restore(db: AnyDatabase, site_id: str, *, by: str, reason: str) -> dict:
    """After a clinic was restored from a backup (a rollback on purpose): void its anchors, so its next round
    anchors the restored chain afresh. Audited; the voided anchors stay in the table."""
    with db.write() as conn:
        peers.trusted(conn, site_id, SiteRole.clinic)
        last = anchors.latest_anchor(conn, site_id)
        voided = anchors.void_anchors(conn, site_id, iso(utcnow()))
        audit.append(
            conn,
            action="peer.accept_restore",
            user_id=None,
            device_id=None,
            kind="peer",
            record_id=site_id,
            detail=f"by {by}: {reason}; {voided} anchors voided, last at entry {last.head.seq if last else '-'}",
        )
    return {
        "site_id": site_id,
        "anchors_voided": voided,
        "last_anchored_seq": last.head.seq if last else None,
        "next": "the site's next sync round anchors its restored audit chain",
    }


def _check_runs_through(site_id: str, head: AuditHead, previous: AuditHead, last: StoredAnchor) -> None:
    seq, when = last.head.seq, last.anchored_at
    if head.seq < seq:
        raise TransferRejected(
            f"{site_id}'s audit chain now ends at entry {head.seq}, but it had reached entry {seq} when this center "
            f"anchored it on {when}: entries were removed or its database was replaced by an older copy",
            code="audit-rollback",
        )
    if previous.hash != last.head.hash:
        raise TransferRejected(
            f"{site_id}'s audit entry {seq} is not the one this center anchored on {when}: its chain was rewritten",
            code="audit-rewritten",
        )
