"""Schema of the center's database: consultants' accounts and the audit trail (as at a gateway), enrolled clinics,
transfers in progress, stored bundles, notes on their way back and rejections.

Each step is written once, in SQLite's DDL; on PostgreSQL the same statements run with its column types
(base/storage/dialect.py). CENTER_STEPS is the order both databases apply them in."""

from __future__ import annotations

from sqlite_utils import Database, Migrations

from base.storage import pacs_sends, schema
from sync.storage.peers import PEERS_DDL

CENTRAL_SET = "burnedge-central"


def c001_center(db: Database) -> None:
    schema.create_accounts(db)
    schema.create_audit_log(db)
    db.execute(PEERS_DDL)
    db.execute(
        """
        CREATE TABLE incoming (
            site_id TEXT NOT NULL,
            bundle_id TEXT NOT NULL,
            envelope BLOB NOT NULL,
            manifest_sha256 TEXT NOT NULL,
            encounter_id TEXT NOT NULL,
            version INTEGER NOT NULL,
            chunks INTEGER NOT NULL,
            announced_at TEXT NOT NULL,
            PRIMARY KEY (site_id, bundle_id)
        )"""
    )
    db.execute(
        """
        CREATE TABLE bundles (
            site_id TEXT NOT NULL,
            bundle_id TEXT NOT NULL,
            encounter_id TEXT NOT NULL,
            patient_id TEXT NOT NULL,
            version INTEGER NOT NULL,
            supersedes TEXT,
            urgency TEXT NOT NULL,
            urgency_rank INTEGER NOT NULL,
            summary TEXT NOT NULL,
            manifest TEXT NOT NULL,
            manifest_sha256 TEXT NOT NULL,
            stored_at TEXT NOT NULL,
            receipt BLOB NOT NULL,
            PRIMARY KEY (site_id, bundle_id),
            UNIQUE (site_id, encounter_id, version)
        )"""
    )
    db.execute(
        """
        CREATE TABLE bundle_parts (
            site_id TEXT NOT NULL,
            bundle_id TEXT NOT NULL,
            name TEXT NOT NULL,
            media_type TEXT NOT NULL,
            sha256 TEXT NOT NULL,
            size INTEGER NOT NULL,
            PRIMARY KEY (site_id, bundle_id, name)
        )"""
    )
    db.execute(
        """
        CREATE TABLE notes (
            seq INTEGER PRIMARY KEY AUTOINCREMENT,
            note_id TEXT NOT NULL UNIQUE,
            site_id TEXT NOT NULL,
            encounter_id TEXT NOT NULL,
            bundle_id TEXT NOT NULL,
            consultant_user_id TEXT NOT NULL,
            note TEXT NOT NULL,
            message BLOB,
            written_at TEXT NOT NULL,
            delivered_at TEXT
        )"""
    )
    db.execute("CREATE INDEX notes_site ON notes (site_id, seq)")
    db.execute("CREATE TABLE mail_cursors (site_id TEXT PRIMARY KEY, acked_seq INTEGER NOT NULL, last_poll_at TEXT)")
    db.execute(
        """
        CREATE TABLE rejections (
            id INTEGER PRIMARY KEY,
            at TEXT NOT NULL,
            site_id TEXT,
            code TEXT NOT NULL,
            reason TEXT NOT NULL,
            key TEXT NOT NULL
        )"""
    )


def c002_audit_anchors(db: Database) -> None:
    """Every audit-chain head a clinic had anchored: a later head must still run through the newest one that is
    not voided (a site restored from a backup has its anchors voided by the center's IT person, audited)."""
    db.execute(
        """
        CREATE TABLE audit_anchors (
            id INTEGER PRIMARY KEY,
            site_id TEXT NOT NULL,
            seq INTEGER NOT NULL,
            hash TEXT NOT NULL,
            anchored_at TEXT NOT NULL,
            voided_at TEXT
        )"""
    )
    db.execute("CREATE INDEX audit_anchors_site ON audit_anchors (site_id, seq)")


def c003_must_change_password(db: Database) -> None:
    """Consultants' accounts share the gateway's account code: an administrator's reset forces a change."""
    schema.add_must_change_password(db)


def c004_case_queue(db: Database) -> None:
    """The consultants' list as indexed columns, so a page of it and its count are read from an index at any number
    of cases: which newer version replaced a bundle (and a flag of it, first in the list's order), and whether a
    note was written since it arrived; kept current by the writes that change them (center/storage/cases.py and
    notes.py)."""
    db.execute("ALTER TABLE bundles ADD COLUMN superseded_by TEXT")
    db.execute("ALTER TABLE bundles ADD COLUMN superseded INTEGER NOT NULL DEFAULT 0")
    db.execute("ALTER TABLE bundles ADD COLUMN advised INTEGER NOT NULL DEFAULT 0")
    db.execute("CREATE INDEX notes_encounter ON notes (site_id, encounter_id, written_at)")
    db.execute(
        "UPDATE bundles SET superseded_by = (SELECT n.bundle_id FROM bundles n WHERE n.site_id = bundles.site_id"
        " AND n.encounter_id = bundles.encounter_id AND n.version > bundles.version ORDER BY n.version DESC LIMIT 1)"
    )
    db.execute("UPDATE bundles SET superseded = CASE WHEN superseded_by IS NULL THEN 0 ELSE 1 END")
    db.execute(
        "UPDATE bundles SET advised = 1 WHERE EXISTS (SELECT 1 FROM notes t WHERE t.site_id = bundles.site_id"
        " AND t.encounter_id = bundles.encounter_id AND t.written_at >= bundles.stored_at)"
    )
    db.execute(
        "CREATE INDEX bundles_queue ON bundles (superseded, advised, urgency_rank, stored_at, site_id, bundle_id)"
    )
    db.execute(
        "CREATE INDEX bundles_site_queue ON bundles (site_id, superseded, advised, urgency_rank, stored_at, bundle_id)"
    )
    db.execute("CREATE INDEX bundles_received ON bundles (stored_at)")


def c005_sealed_at_rest(db: Database) -> None:
    """Bundles kept as the clinic sealed them (center/sealed_bundles.py): the sealed key, chunk count and chunk
    size of each, and where each file starts in its plaintext. Bundles stored before keep their plain files (NULL
    here)."""
    db.execute("ALTER TABLE bundles ADD COLUMN sealed_key BLOB")
    db.execute("ALTER TABLE bundles ADD COLUMN chunks INTEGER")
    db.execute("ALTER TABLE bundles ADD COLUMN chunk_bytes INTEGER")
    db.execute("ALTER TABLE bundle_parts ADD COLUMN plain_offset INTEGER")


def c006_refused_bundles(db: Database) -> None:
    """Bundles refused whole at commit, with the reason: a commit sent again (its answer lost on the way, or taken
    by two workers at once) is told the same reason rather than that the bundle was never announced."""
    db.execute(
        """
        CREATE TABLE refused_bundles (
            site_id TEXT NOT NULL,
            bundle_id TEXT NOT NULL,
            code TEXT NOT NULL,
            reason TEXT NOT NULL,
            refused_at TEXT NOT NULL,
            PRIMARY KEY (site_id, bundle_id)
        )"""
    )
    db.execute("CREATE INDEX refused_bundles_at ON refused_bundles (refused_at)")


def c007_pacs_sends(db: Database) -> None:
    """Each forwarding of a received case to the hospital's PACS (base/storage/pacs_sends.py)."""
    pacs_sends.create_table(db)


CENTER_STEPS = (
    c001_center,
    c002_audit_anchors,
    c003_must_change_password,
    c004_case_queue,
    c005_sealed_at_rest,
    c006_refused_bundles,
    c007_pacs_sends,
)
central_migrations = Migrations(CENTRAL_SET)
for _step in CENTER_STEPS:
    central_migrations()(_step)
