"""What consultants do at the center: read incoming cases by urgency, open one, write advice back to the clinic."""

from __future__ import annotations

import sqlite3
import uuid

import msgspec

from base.accounts.permissions import Principal
from base.storage import audit
from base.storage.database import Database
from center.files import PartStore
from schemas.accounts import Role
from schemas.base import iso, utcnow
from schemas.central import CaseDetail, CaseItem, NoteRequest, NoteStatus, RejectionItem
from schemas.errors import Forbidden, NotFound, TransferRejected
from schemas.transfer import BundleManifest, CaseSummary, ConsultationNote, SiteIdentity, SiteRole, Urgency
from sync import peers
from sync.keys import SiteKeys
from sync.mailbox import seal_note

READERS = frozenset({Role.consultant, Role.clinician})
_CASE_SQL = """
    SELECT b.*, p.identity AS peer_identity,
        (SELECT n.bundle_id FROM bundles n WHERE n.site_id = b.site_id AND n.encounter_id = b.encounter_id
            AND n.version > b.version ORDER BY n.version DESC LIMIT 1) AS superseded_by,
        (SELECT COUNT(*) FROM notes t WHERE t.site_id = b.site_id AND t.encounter_id = b.encounter_id) AS notes,
        (SELECT COUNT(*) FROM notes t WHERE t.site_id = b.site_id AND t.encounter_id = b.encounter_id
            AND t.written_at >= b.stored_at) AS notes_since
    FROM bundles b JOIN peers p ON p.site_id = b.site_id"""


class CaseService:
    def __init__(self, db: Database, keys: SiteKeys, parts: PartStore):
        self.db = db
        self.keys = keys
        self.parts = parts

    def list_cases(self, who: Principal, *, include_superseded: bool = False, limit: int = 200) -> list[CaseItem]:
        """Latest version of each case; awaiting advice first, then most urgent, then longest waiting."""
        _require(who, READERS)
        rows = self.db.connection().execute(_CASE_SQL + " ORDER BY b.urgency_rank, b.stored_at").fetchall()
        items = [_item(r) for r in rows]
        if not include_superseded:
            items = [i for i in items if i.superseded_by is None]
        items.sort(key=lambda i: (not i.awaiting_advice,))  # stable: urgency order kept within each group
        return items[:limit]

    def case(self, who: Principal, site_id: str, bundle_id: str) -> CaseDetail:
        _require(who, READERS)
        conn = self.db.connection()
        row = conn.execute(_CASE_SQL + " WHERE b.site_id = ? AND b.bundle_id = ?", (site_id, bundle_id)).fetchone()
        if row is None:
            raise NotFound(f"no case {bundle_id} from {site_id}")
        versions = conn.execute(
            _CASE_SQL + " WHERE b.site_id = ? AND b.encounter_id = ? ORDER BY b.version DESC",
            (site_id, row["encounter_id"]),
        ).fetchall()
        notes = conn.execute(
            "SELECT note, delivered_at FROM notes WHERE site_id = ? AND encounter_id = ? ORDER BY seq",
            (site_id, row["encounter_id"]),
        ).fetchall()
        return CaseDetail(
            case=_item(row),
            manifest=msgspec.json.decode(row["manifest"], type=BundleManifest),
            versions=[_item(v) for v in versions],
            notes=[
                NoteStatus(note=msgspec.json.decode(n["note"], type=ConsultationNote), delivered_at=n["delivered_at"])
                for n in notes
            ],
        )

    def part(self, who: Principal, site_id: str, bundle_id: str, name: str) -> tuple[bytes, str]:
        _require(who, READERS)
        row = (
            self.db.connection()
            .execute(
                "SELECT sha256, media_type FROM bundle_parts WHERE site_id = ? AND bundle_id = ? AND name = ?",
                (site_id, bundle_id, name),
            )
            .fetchone()
        )
        if row is None:
            raise NotFound(f"case {bundle_id} has no part {name!r}: its manifest lists the parts")
        return self.parts.read(row["sha256"]), row["media_type"]

    def write_note(self, who: Principal, site_id: str, bundle_id: str, body: NoteRequest) -> NoteStatus:
        """Store a consultant's note and seal it for the clinic, which fetches it at its next round."""
        _require(who, frozenset({Role.consultant}))
        with self.db.write() as conn:
            row = conn.execute(
                "SELECT * FROM bundles WHERE site_id = ? AND bundle_id = ?", (site_id, bundle_id)
            ).fetchone()
            if row is None:
                raise NotFound(f"no case {bundle_id} from {site_id}")
            clinic = _clinic(conn, site_id)
            note = ConsultationNote(
                note_id=str(uuid.uuid4()),
                encounter_id=row["encounter_id"],
                patient_id=row["patient_id"],
                bundle_id=bundle_id,
                bundle_version=row["version"],
                center_id=self.keys.site_id,
                consultant=_display(conn, who),
                consultant_user_id=who.user_id,
                written_at=iso(utcnow()),
                recommendation=body.recommendation,
                advice=body.advice,
            )
            cur = conn.execute(
                "INSERT INTO notes (note_id, site_id, encounter_id, bundle_id, consultant_user_id, note,"
                " written_at) VALUES (?,?,?,?,?,?,?)",
                (
                    note.note_id,
                    site_id,
                    note.encounter_id,
                    bundle_id,
                    who.user_id,
                    msgspec.json.encode(note).decode(),
                    note.written_at,
                ),
            )
            message = seal_note(self.keys, clinic, cur.lastrowid, note)
            conn.execute("UPDATE notes SET message = ? WHERE seq = ?", (msgspec.msgpack.encode(message), cur.lastrowid))
            audit.append(
                conn,
                action="consultation.write",
                user_id=who.user_id,
                device_id=None,
                kind="consultation",
                record_id=note.note_id,
                detail=f"{note.recommendation.value} for encounter "
                f"{note.encounter_id} at {site_id} (bundle {bundle_id} v{row['version']})",
            )
        return NoteStatus(note=note, delivered_at=None)

    def rejections(self, who: Principal, limit: int = 100) -> list[RejectionItem]:
        _require(who, frozenset({Role.admin, Role.consultant}))
        rows = self.db.connection().execute("SELECT * FROM rejections ORDER BY id DESC LIMIT ?", (limit,))
        return [
            RejectionItem(at=r["at"], site_id=r["site_id"], code=r["code"], reason=r["reason"], key=r["key"])
            for r in rows
        ]


def _require(who: Principal, roles: frozenset[Role]) -> None:
    if who.role not in roles:
        raise Forbidden(f"a {who.role.value} may not do this here (needs: {', '.join(sorted(r.value for r in roles))})")


def _clinic(conn: sqlite3.Connection, site_id: str) -> SiteIdentity:
    try:
        return peers.trusted(conn, site_id, SiteRole.clinic)
    except TransferRejected as exc:
        raise Forbidden(f"advice cannot be sent to {site_id}: {exc.detail}") from exc


def _display(conn: sqlite3.Connection, who: Principal) -> str:
    row = conn.execute("SELECT display_name FROM users WHERE id = ?", (who.user_id,)).fetchone()
    return (row["display_name"] if row and row["display_name"] else who.username)[:200]


def _item(row: sqlite3.Row) -> CaseItem:
    identity = msgspec.json.decode(row["peer_identity"], type=SiteIdentity)
    return CaseItem(
        site_id=row["site_id"],
        site_name=identity.name,
        bundle_id=row["bundle_id"],
        encounter_id=row["encounter_id"],
        patient_id=row["patient_id"],
        version=row["version"],
        urgency=Urgency(row["urgency"]),
        summary=msgspec.json.decode(row["summary"], type=CaseSummary),
        stored_at=row["stored_at"],
        superseded_by=row["superseded_by"],
        notes=row["notes"],
        awaiting_advice=row["notes_since"] == 0,
    )
