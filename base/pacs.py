"""A send to the hospital's PACS as both servers record it (the clinic's gateway/documents/dicom.py, the burn center's
center/pacs.py): recorded as "sending" before the study leaves, then finished as sent or failed, each with its
audit entry in the same transaction. Only a send the PACS confirmed for every object is marked as sent."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import msgspec

from base.storage import audit, pacs_sends
from schemas.base import iso, utcnow
from schemas.dicom import PacsOutcome, PacsSend, PacsSendState
from schemas.errors import PacsFailed
from schemas.ids import uuid7

STALE_S = 60
"""A send still "sending" this long after it started was cut short (its server stopped): shown as failed."""


@dataclass(frozen=True)
class Subject:
    """What is sent and who asked, as the audit log names them."""

    kind: str
    """The audit entry's kind: "encounter" at the clinic, "case" at the burn center."""
    record_id: str
    requested_by: str
    user_id: str | None = None
    device_id: str | None = None


def send_recorded(
    db, subject: Subject, endpoint: str, study_uid: str, instances: int, transmit: Callable[[], PacsOutcome]
) -> PacsSend:
    """Record the send, run `transmit` (which raises PacsFailed), and finish the record; the send as recorded. A
    failure is recorded with its reason, audited and raised again: nothing is marked as sent."""
    started = PacsSend(
        id=uuid7(),
        subject_id=subject.record_id,
        endpoint=endpoint,
        state=PacsSendState.sending,
        study_uid=study_uid,
        requested_by=subject.requested_by,
        started_at=iso(utcnow()),
        instances=instances,
    )
    with db.write() as conn:
        pacs_sends.begin(conn, started)
    try:
        outcome = transmit()
    except PacsFailed as exc:
        with db.write() as conn:
            pacs_sends.finish(conn, started.id, PacsSendState.failed, iso(utcnow()), error=exc.detail)
            _audit(conn, subject, "dicom.send_failed", exc.detail)
        raise
    sent = msgspec.structs.replace(
        started,
        state=PacsSendState.sent,
        finished_at=iso(utcnow()),
        instances=outcome.instances,
        already_there=outcome.already_there,
    )
    with db.write() as conn:
        pacs_sends.finish(
            conn,
            sent.id,
            sent.state,
            sent.finished_at or "",
            instances=sent.instances,
            already_there=sent.already_there,
        )
        detail = (
            f"study {outcome.study_uid} to {outcome.endpoint}: {outcome.instances} objects stored"
            f" ({outcome.already_there} already there)"
        )
        _audit(conn, subject, "dicom.send", detail)
    return sent


def sends_of(db, subject_id: str) -> list[PacsSend]:
    """The subject's sends, newest first; one left "sending" by a stopped server reads as failed."""
    with db.read() as conn:
        found = pacs_sends.of_subject(conn, subject_id)
    return [pacs_sends.settled(s, STALE_S) for s in found]


def _audit(conn, subject: Subject, action: str, detail: str) -> None:
    audit.append(
        conn,
        action=action,
        user_id=subject.user_id,
        device_id=subject.device_id,
        kind=subject.kind,
        record_id=subject.record_id,
        detail=detail,
    )
