"""What consultants do at the center: read incoming cases by urgency, open one, write advice back to the clinic."""

from __future__ import annotations

import itertools
import sqlite3
import uuid
from collections.abc import Iterator
from pathlib import Path

from base.accounts.permissions import Principal
from base.storage import accounts, audit
from base.storage.postgres import AnyDatabase
from center.files import PartStore
from center.sealed_bundles import SealedBundles
from center.storage import case_queue, cases, notes, rejections
from schemas.accounts import Role
from schemas.base import iso, utcnow
from schemas.central import CaseDetail, CaseFilter, CasePage, NoteRequest, NoteStatus, RejectionItem
from schemas.errors import Forbidden, NotFound, TransferRejected
from schemas.transfer import ConsultationNote, SiteIdentity, SiteRole
from sync import peers
from sync.keys import SiteKeys
from sync.mailbox import seal_note

READERS = frozenset({Role.consultant, Role.clinician})
COUNT_UP_TO = 10_000
"""The case list counts the cases a filter matches up to this many ("10000+" beyond)."""


class CaseService:
    def __init__(self, db: AnyDatabase, keys: SiteKeys, store_dir: Path):
        self.db = db
        self.keys = keys
        self.bundles = SealedBundles(store_dir / "bundles", keys.box)
        self.plain_parts = PartStore(store_dir / "parts")
        """Files of bundles stored before the center kept them sealed."""

    def list_cases(self, who: Principal, wanted: CaseFilter | None = None) -> CasePage:
        """A page of the cases the filter picks: awaiting advice first, then most urgent, then longest waiting."""
        _require(who, READERS)
        wanted = wanted or CaseFilter()
        with self.db.read() as conn:
            items, next_after = case_queue.page_of_cases(conn, wanted)
            counted = case_queue.count_cases(conn, wanted, COUNT_UP_TO)
        return CasePage(
            cases=items, total=min(counted, COUNT_UP_TO), total_capped=counted > COUNT_UP_TO, next_after=next_after
        )

    def case(self, who: Principal, site_id: str, bundle_id: str) -> CaseDetail:
        _require(who, READERS)
        conn = self.db.connection()
        stored = cases.find_case(conn, site_id, bundle_id)
        if stored is None:
            raise NotFound(f"no case {bundle_id} from {site_id}")
        encounter_id = stored.case.encounter_id
        return CaseDetail(
            case=stored.case,
            manifest=stored.manifest,
            versions=cases.case_versions(conn, site_id, encounter_id),
            notes=notes.encounter_notes(conn, site_id, encounter_id),
        )

    def part(self, who: Principal, site_id: str, bundle_id: str, name: str) -> tuple[bytes, str]:
        """One file of a case, whole (the record, the patient: small files the pages read)."""
        pieces, media_type, _ = self.part_stream(who, site_id, bundle_id, name)
        return b"".join(pieces), media_type

    def part_stream(self, who: Principal, site_id: str, bundle_id: str, name: str) -> tuple[Iterator[bytes], str, int]:
        """One file of a case as it is decrypted, its media type and size."""
        _require(who, READERS)
        part = cases.find_part(self.db.connection(), site_id, bundle_id, name)
        if part is None:
            raise NotFound(f"case {bundle_id} has no part {name!r}: its manifest lists the parts")
        if part.sealed_key is None:
            return iter([self.plain_parts.read(part.sha256)]), part.media_type, part.size
        pieces = self.bundles.read(site_id, bundle_id, part)
        first = next(pieces, b"")  # a missing or damaged start is an error answer, not a cut-off download
        return itertools.chain([first], pieces), part.media_type, part.size

    def write_note(self, who: Principal, site_id: str, bundle_id: str, body: NoteRequest) -> NoteStatus:
        """Store a consultant's note and seal it for the clinic, which fetches it at its next round."""
        _require(who, frozenset({Role.consultant}))
        with self.db.write() as conn:
            stored = cases.find_bundle(conn, site_id, bundle_id)
            if stored is None:
                raise NotFound(f"no case {bundle_id} from {site_id}")
            clinic = _clinic(conn, site_id)
            note = ConsultationNote(
                note_id=str(uuid.uuid4()),
                encounter_id=stored.encounter_id,
                patient_id=stored.patient_id,
                bundle_id=bundle_id,
                bundle_version=stored.version,
                center_id=self.keys.site_id,
                consultant=_display(conn, who),
                consultant_user_id=who.user_id,
                written_at=iso(utcnow()),
                recommendation=body.recommendation,
                advice=body.advice,
            )
            seq = notes.insert_note(conn, site_id, note)
            notes.attach_sealed(conn, seq, seal_note(self.keys, clinic, seq, note))
            audit.append(
                conn,
                action="consultation.write",
                user_id=who.user_id,
                device_id=None,
                kind="consultation",
                record_id=note.note_id,
                detail=f"{note.recommendation.value} for encounter "
                f"{note.encounter_id} at {site_id} (bundle {bundle_id} v{stored.version})",
            )
        return NoteStatus(note=note, delivered_at=None)

    def rejections(self, who: Principal, limit: int = 100) -> list[RejectionItem]:
        _require(who, frozenset({Role.admin, Role.consultant}))
        return rejections.latest_rejections(self.db.connection(), limit)


def _require(who: Principal, roles: frozenset[Role]) -> None:
    if who.role not in roles:
        raise Forbidden(f"a {who.role.value} may not do this here (needs: {', '.join(sorted(r.value for r in roles))})")


def _clinic(conn: sqlite3.Connection, site_id: str) -> SiteIdentity:
    try:
        return peers.trusted(conn, site_id, SiteRole.clinic)
    except TransferRejected as exc:
        raise Forbidden(f"advice cannot be sent to {site_id}: {exc.detail}") from exc


def _display(conn: sqlite3.Connection, who: Principal) -> str:
    stored = accounts.find_user(conn, who.user_id)
    return (stored.user.display_name if stored and stored.user.display_name else who.username)[:200]
