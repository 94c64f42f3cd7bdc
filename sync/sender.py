"""The clinic's sync round: connect out to the center, deliver queued bundles, fetch the consultants' advice.

Each bundle: announce the signed manifest (the center answers with the chunks it already holds), send the rest
with a window of requests in flight, then ask the center to commit; only its signed receipt marks the bundle
delivered. A round that loses the link stops; the next round resumes from what the center holds.
"""

from __future__ import annotations

import hashlib
import logging
import time
from collections import deque
from dataclasses import dataclass, field

import msgspec

from base.storage.database import Database
from schemas.audit import AuditAnchor
from schemas.config import Config
from schemas.errors import TransferRejected
from schemas.transfer import (
    AnnounceReply,
    ChunkRef,
    CommitReply,
    OutboxBundle,
    Receipt,
    SignedEnvelope,
    SiteIdentity,
    TransferManifest,
)
from sync import anchor, mailbox, peers
from sync.keys import SiteKeys, verify_envelope
from sync.outbox import Outbox
from sync.wire import LinkDown, error_text, request
from sync.zenoh_link import Keys, open_clinic_session

log = logging.getLogger("burnedge.sync")
_PROGRESS_EVERY_S = 1.0


@dataclass
class RoundReport:
    delivered: list[str] = field(default_factory=list)
    rejected: dict[str, str] = field(default_factory=dict)
    notes_received: int = 0
    chunks_sent: int = 0
    anchor: AuditAnchor | None = None
    anchor_problem: str | None = None
    """The center's reason for refusing to anchor the audit chain (it no longer runs through the last anchor)."""


class Sender:
    def __init__(self, db: Database, config: Config, keys: SiteKeys):
        self.db = db
        self.config = config
        self.keys = keys
        self.outbox = Outbox(db, config)

    def run_round(self) -> RoundReport:
        """One round over one session; raises LinkDown when the center cannot be reached or stops answering."""
        report = RoundReport()
        center = peers.only_center(self.db.connection(), self.config.sync.center_id)
        link = Keys(self.config.sync.key_prefix, center.site_id)
        with open_clinic_session(self.config.sync) as session:
            for queued in self.outbox.pending():
                bundle_id = queued.entry.bundle_id
                try:
                    self._deliver(session, link, center, queued, report)
                except TransferRejected as exc:
                    log.warning("center %s rejected bundle %s: %s", center.site_id, bundle_id, exc.detail)
                    self.outbox.failed_attempt(bundle_id, f"rejected by the center: {exc.detail}")
                    report.rejected[bundle_id] = exc.detail
                except LinkDown as exc:
                    self.outbox.failed_attempt(bundle_id, exc.detail)
                    raise
            report.notes_received = mailbox.fetch(session, link, self.db, self.keys, center, self.config)
            try:  # last: the notes just stored are audited entries too
                report.anchor = anchor.exchange(session, link, self.db, self.keys, center, self.config)
            except TransferRejected as exc:
                log.error("the burn center refused to anchor this gateway's audit chain: %s", exc.detail)
                report.anchor_problem = exc.detail
        return report

    def _deliver(self, session, link: Keys, center: SiteIdentity, queued: OutboxBundle, report: RoundReport) -> None:
        bundle_id = queued.entry.bundle_id
        envelope_bytes = queued.envelope
        timeout = self.config.sync.query_timeout_s
        reply = msgspec.msgpack.decode(
            request(session, link.announce(self.keys.site_id), envelope_bytes, timeout), type=AnnounceReply
        )
        if reply.status == "stored" and reply.receipt is not None:
            self._accept_receipt(center, queued, reply.receipt)
            report.delivered.append(bundle_id)
            return
        manifest_refs = msgspec.msgpack.decode(self.outbox.envelope(queued).body, type=TransferManifest).chunks
        held = set(reply.held)
        need = [i for i in range(len(manifest_refs)) if i not in held]
        for _ in range(3):  # a center that lost unsynced chunks in a crash says which are missing at commit
            report.chunks_sent += self._send_chunks(
                session, link, bundle_id, manifest_refs, need, len(manifest_refs) - len(need)
            )
            commit = msgspec.msgpack.decode(
                request(session, link.commit(self.keys.site_id, bundle_id), b"", timeout), type=CommitReply
            )
            if commit.status == "stored" and commit.receipt is not None:
                self._accept_receipt(center, queued, commit.receipt)
                report.delivered.append(bundle_id)
                return
            need = commit.missing
        raise TransferRejected(f"the center still misses chunks of {bundle_id} after three sends", code="incomplete")

    def _send_chunks(
        self, session, link: Keys, bundle_id: str, refs: list[ChunkRef], need: list[int], held: int
    ) -> int:
        timeout = self.config.sync.query_timeout_s
        window: deque = deque()
        acked, last_saved = held, time.monotonic()

        def settle() -> None:
            nonlocal acked, last_saved
            index, pending = window.popleft()
            for reply in pending:
                if reply.ok is None:
                    raise TransferRejected(f"chunk {index}: {error_text(reply)}", code="chunk-refused")
                acked += 1
                break
            else:
                raise LinkDown(f"chunk {index} of bundle {bundle_id} got no acknowledgement within {timeout:g} s")
            if time.monotonic() - last_saved > _PROGRESS_EVERY_S:
                self.outbox.progress(bundle_id, acked)
                last_saved = time.monotonic()

        for index in need:
            if len(window) >= self.config.sync.window_chunks:
                settle()
            key = link.chunk(self.keys.site_id, bundle_id, index, refs[index].sha256)
            window.append((index, session.get(key, payload=self.outbox.chunk(bundle_id, index, refs), timeout=timeout)))
        while window:
            settle()
        self.outbox.progress(bundle_id, acked)
        return len(need)

    def _accept_receipt(self, center: SiteIdentity, queued: OutboxBundle, receipt_env: SignedEnvelope) -> None:
        bundle_id = queued.entry.bundle_id
        try:
            verify_envelope(receipt_env, center)
            receipt = msgspec.msgpack.decode(receipt_env.body, type=Receipt)
        except Exception as exc:
            raise TransferRejected(
                f"the receipt for {bundle_id} is not signed by {center.site_id}", code="bad-receipt"
            ) from exc
        body_sha = hashlib.sha256(self.outbox.envelope(queued).body).hexdigest()
        if receipt_env.kind != "receipt" or receipt.bundle_id != bundle_id or receipt.manifest_sha256 != body_sha:
            raise TransferRejected(f"the receipt does not match bundle {bundle_id}", code="bad-receipt")
        self.outbox.delivered(bundle_id, receipt_env)
        log.info(
            "bundle %s delivered to %s%s",
            bundle_id,
            center.site_id,
            " (it was already stored)" if receipt.duplicate else "",
        )
