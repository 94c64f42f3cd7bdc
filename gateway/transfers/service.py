"""Sending a case to the burn center and reading the advice that came back, with the gateway's permissions."""

from __future__ import annotations

import msgspec

from base.accounts.permissions import Principal, require_read
from base.storage import records as store
from gateway.documents.reports import ReportService
from gateway.records.snapshot import current_snapshot
from gateway.storage import advice as advice_store
from gateway.storage.advice import UnreadAdvice
from gateway.storage.database import Database
from gateway.transfers.link import LinkService
from gateway.transfers.send_preview import SendPreview, grouped
from schemas.accounts import Role
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.encounter_snapshot import EncounterSnapshot
from schemas.errors import Conflict, Forbidden
from schemas.patient import SharingConsent
from schemas.records import Record, RecordKind
from schemas.transfer import OutboxEntry, SyncStatus
from schemas.wound_healing import PatientHealing
from sync.bundle import PartData
from sync.service import SyncService

READERS = frozenset({Role.clinician, Role.nurse})
"""Who reads the advice at the clinic: it counts as read once one of them has opened its encounter."""
SENDERS = frozenset({Role.clinician})
"""Sending a patient's record off site is the treating clinician's decision."""


class TransferService:
    def __init__(self, db: Database, config: Config, reports: ReportService):
        self.db = db
        self.config = config
        self.sync = SyncService(db, config)
        self.link = LinkService(db, config, self.sync)
        self.reports = reports

    def send(self, who: Principal, encounter_id: str) -> OutboxEntry:
        if who.role not in SENDERS:
            raise Forbidden("only a clinician may send a case to the burn center")
        require_read(who, RecordKind.encounter)
        self._check_consent(encounter_id)
        return self.queue(encounter_id, who.username, who)

    def send_from_console(self, encounter_id: str, by: str) -> OutboxEntry:
        """`burnedge sync send`: the same consent rule as a clinician's sending."""
        self._check_consent(encounter_id)
        return self.queue(encounter_id, by)

    def _check_consent(self, encounter_id: str) -> None:
        """A case leaves the clinic only once the patient's choice is recorded, and never against a refusal."""
        encounter = store.get_head(self.db.connection(), RecordKind.encounter, encounter_id)  # NotFound first
        consent = encounter.value().sharing_consent
        if consent is SharingConsent.refused:
            raise Conflict("the patient refused that this case be sent: it stays at the clinic", current=encounter)
        if consent is None:
            raise Conflict(
                "the patient's consent to sending the case is not recorded: ask them, then record it on the encounter"
                " (sharing_consent: given, given_by_guardian, or not_possible when no one can be asked)",
                current=encounter,
            )

    def preview(self, who: Principal, encounter_id: str) -> SendPreview:
        """To whom the case would go and what it would carry now (nothing is queued)."""
        if who.role not in SENDERS:
            raise Forbidden("only a clinician may send a case to the burn center")
        self.sync.keys()  # a clinic not linked to a center says so
        read = current_snapshot(self.db, self.config, encounter_id, who.username)
        center, parts = self.sync.outbox.preview(read)
        return SendPreview(center=center, groups=grouped(parts), consent=read.encounter.value.sharing_consent)

    def queue(self, encounter_id: str, by: str, who: Principal | None = None) -> OutboxEntry:
        """Read the encounter once and queue it with the report and the wounds' healing made from that reading:
        the consultant reads the same report the clinic prints (who None: the gateway itself, the CLI)."""
        self.sync.keys()  # a clinic not linked to a center says so before a report is made

        def made_from(snapshot: EncounterSnapshot) -> tuple[PartData, ...]:
            report = self.reports.make_from(who, snapshot)
            healing = PatientHealing(patient_id=snapshot.patient.value.id, wounds=snapshot.healing)
            return (PartData("report.pdf", report.pdf), PartData("healing.json", msgspec.json.encode(healing)))

        return self.sync.queue(lambda: self.reports.current(encounter_id, by), by, made_from)

    def transfers(self, who: Principal, encounter_id: str) -> list[OutboxEntry]:
        require_read(who, RecordKind.encounter)
        store.get_head(self.db.connection(), RecordKind.encounter, encounter_id)
        return self.sync.outbox.entries(encounter_id)

    def all_transfers(self, who: Principal) -> list[OutboxEntry]:
        _require_staff(who, "the outbox")
        return self.sync.outbox.entries()

    def consultations(self, who: Principal, encounter_id: str) -> list[Record]:
        require_read(who, RecordKind.consultation)
        conn = self.db.connection()
        store.get_head(conn, RecordKind.encounter, encounter_id)
        return store.list_heads(conn, RecordKind.consultation, parent_id=encounter_id, limit=None)

    def unread_advice(self, who: Principal) -> list[UnreadAdvice]:
        """Consultant advice the clinic has not read yet (none for those who do not read patients' records)."""
        if who.role not in READERS:
            return []
        with self.db.read() as conn:
            return advice_store.unread(conn)

    def mark_advice_read(self, who: Principal, encounter_id: str) -> set[str]:
        """The encounter's advice as read by `who` (it was shown to them); the consultations that were new."""
        if who.role not in READERS:
            return set()
        with self.db.read() as conn:  # most openings find nothing new: no write transaction for them
            new = [a for a in advice_store.unread(conn) if a.encounter_id == encounter_id]
        if new:
            with self.db.write() as conn:  # INSERT OR IGNORE: read at the same time by two people, kept once
                advice_store.mark_read(conn, new, who.username, iso(utcnow()))
        return {a.consultation_id for a in new}

    def status(self, who: Principal) -> SyncStatus:
        _require_staff(who, "the link to the burn center")
        return self.sync.status()


def _require_staff(who: Principal, what: str) -> None:
    if who.role not in (Role.admin, Role.clinician, Role.nurse):
        raise Forbidden(f"only clinic staff see {what}")
