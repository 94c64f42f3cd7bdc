"""Consultants' notes from the center to a clinic: sealed to the clinic, signed by the center, fetched by the clinic.

The clinic asks (it is behind NAT; the center cannot call it), naming the last message it stored; the center
answers with the messages after it. A note is stored once at the clinic, as a `consultation` record of its
encounter (audited, in the phones' change feed), in the same transaction that moves the cursor on.
"""

from __future__ import annotations

import logging

import msgspec

from base.storage import audit
from base.storage import records as store
from base.storage.database import Database
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.errors import TransferRejected
from schemas.records import RecordKind
from schemas.transfer import Consultation, ConsultationNote, MailRequest, SealedMessage, SignedEnvelope, SiteIdentity
from sync.keys import SiteKeys, verify_envelope
from sync.sealing import open_chunks, seal, unseal_key
from sync.storage import state as sync_state
from sync.wire import request
from sync.zenoh_link import Keys

log = logging.getLogger("burnedge.sync")


def seal_note(center: SiteKeys, recipient: SiteIdentity, seq: int, note: ConsultationNote) -> SignedEnvelope:
    plain = msgspec.json.encode(note)
    sealed = seal(plain, bytes.fromhex(recipient.box_key), _context(recipient.site_id, seq), max(1, len(plain)))
    message = SealedMessage(
        seq=seq, recipient=recipient.site_id, sealed_key=sealed.sealed_key, ciphertext=sealed.chunks[0]
    )
    return center.sign("note", message)


def open_note(envelope: SignedEnvelope, center: SiteIdentity, own: SiteKeys) -> tuple[int, ConsultationNote]:
    try:
        verify_envelope(envelope, center)
    except Exception as exc:
        raise TransferRejected(f"a message is not signed by {center.site_id}", code="bad-signature") from exc
    if envelope.kind != "note" or envelope.signer != center.site_id:
        raise TransferRejected(f"a {envelope.kind!r} message from {envelope.signer} is not a note", code="bad-kind")
    message = msgspec.msgpack.decode(envelope.body, type=SealedMessage)
    if message.recipient != own.site_id:
        raise TransferRejected(f"note {message.seq} is for {message.recipient}", code="wrong-recipient")
    key = unseal_key(message.sealed_key, own.box)
    (plain,) = open_chunks(key, _context(own.site_id, message.seq), [message.ciphertext], 1)
    return message.seq, msgspec.json.decode(plain, type=ConsultationNote)


ACK_ASKS = 3
"""Asks after the first while notes keep coming: each names the last note stored, which is the center's receipt,
so a consultant sees the advice delivered once the clinic stored it, not a sync round later."""


def fetch(session, link: Keys, db: Database, keys: SiteKeys, center: SiteIdentity, config: Config) -> int:
    """Ask the center for new notes and store them, then ask again (the receipt) while any came; returns how
    many were new."""
    new = 0
    for _ in range(1 + ACK_ASKS):
        before = sync_state.mail_cursor(db.connection(), center.site_id)
        new += _ask(session, link, db, keys, center, config)
        if sync_state.mail_cursor(db.connection(), center.site_id) == before:
            break  # nothing stored moved the cursor: the center already has the receipt
    return new


def _ask(session, link: Keys, db: Database, keys: SiteKeys, center: SiteIdentity, config: Config) -> int:
    """One mail request naming the last note stored; how many notes were new."""
    after = sync_state.mail_cursor(db.connection(), center.site_id)
    ask = keys.sign(
        "mail-request", MailRequest(site_id=keys.site_id, center_id=center.site_id, after=after, sent_at=iso(utcnow()))
    )
    raw = request(session, link.mail(keys.site_id), msgspec.msgpack.encode(ask), config.sync.query_timeout_s)
    new = 0
    for envelope in msgspec.msgpack.decode(raw, type=list[SignedEnvelope]):
        try:
            seq, note = open_note(envelope, center, keys)
        except (TransferRejected, msgspec.DecodeError) as exc:
            # Skipped, not retried: what fails these checks was not written by the center we trust.
            log.error("a message from %s was rejected: %s", center.site_id, getattr(exc, "detail", exc))
            continue
        new += _store(db, note, center.site_id, seq)
    return new


def _store(db: Database, note: ConsultationNote, center_id: str, seq: int) -> int:
    with db.write() as conn:
        sync_state.advance_mail_cursor(conn, center_id, seq)
        if store.find_head(conn, RecordKind.consultation, note.note_id) is not None:
            return 0
        record = Consultation(encounter_id=note.encounter_id, note=note, received_at=iso(utcnow()), signed_by=center_id)
        audit.insert_server_record(
            conn,
            kind=RecordKind.consultation,
            record_id=note.note_id,
            parent_id=note.encounter_id,
            data=msgspec.json.encode(record),
            action="consultation.receive",
            detail=f"from {note.consultant} at {center_id}: {note.recommendation.value}",
        )
    log.info("consultation note %s from %s for encounter %s stored", note.note_id, note.consultant, note.encounter_id)
    return 1


def _context(recipient: str, seq: int) -> str:
    return f"mail/{recipient}/{seq}"
