"""Schema migrations, applied in order and recorded by sqlite-utils.

Never edit a released migration: add a new one.
"""

from __future__ import annotations

from sqlite_utils import Database, Migrations

from base.storage import pacs_sends, schema

migrations = Migrations("burnedge")


@migrations()
def m001_records(db: Database) -> None:
    db.execute(
        """
        CREATE TABLE record_versions (
            seq INTEGER PRIMARY KEY AUTOINCREMENT,
            kind TEXT NOT NULL,
            id TEXT NOT NULL,
            version INTEGER NOT NULL,
            parent_id TEXT,
            data TEXT NOT NULL,
            deleted INTEGER NOT NULL DEFAULT 0,
            delete_reason TEXT,
            created_at TEXT NOT NULL,
            updated_at TEXT NOT NULL,
            updated_by TEXT NOT NULL,
            device_id TEXT,
            UNIQUE (kind, id, version)
        )"""
    )
    # The current version of each record; the change feed reads record_versions by seq.
    db.execute(
        """
        CREATE TABLE record_heads (
            kind TEXT NOT NULL,
            id TEXT NOT NULL,
            seq INTEGER NOT NULL REFERENCES record_versions(seq),
            parent_id TEXT,
            deleted INTEGER NOT NULL DEFAULT 0,
            PRIMARY KEY (kind, id)
        ) WITHOUT ROWID"""
    )
    db.execute("CREATE INDEX record_heads_parent ON record_heads (parent_id, kind)")
    db.execute(
        """
        CREATE TABLE applied_mutations (
            mutation_id TEXT PRIMARY KEY,
            fingerprint TEXT NOT NULL,
            result TEXT NOT NULL,
            applied_at TEXT NOT NULL,
            user_id TEXT
        ) WITHOUT ROWID"""
    )


@migrations()
def m002_accounts(db: Database) -> None:
    schema.create_accounts(db)


@migrations()
def m003_audit(db: Database) -> None:
    schema.create_audit_log(db)


@migrations()
def m004_uploads_and_assets(db: Database) -> None:
    db.execute(
        """
        CREATE TABLE uploads (
            id TEXT PRIMARY KEY,
            encounter_id TEXT NOT NULL,
            length INTEGER NOT NULL,
            metadata TEXT NOT NULL,
            filename TEXT NOT NULL,
            state TEXT NOT NULL,
            created_by TEXT NOT NULL,
            device_id TEXT,
            created_at TEXT NOT NULL,
            expires_at TEXT NOT NULL,
            asset_id TEXT,
            error TEXT
        )"""
    )
    db.execute("CREATE INDEX uploads_expiry ON uploads (state, expires_at)")
    db.execute(
        """
        CREATE TABLE assets (
            id TEXT PRIMARY KEY,
            encounter_id TEXT NOT NULL,
            kind TEXT NOT NULL,
            media_type TEXT NOT NULL,
            sha256 TEXT NOT NULL,
            size_bytes INTEGER NOT NULL,
            filename TEXT NOT NULL,
            metadata TEXT NOT NULL,
            verdict TEXT,
            source_asset_id TEXT,
            created_at TEXT NOT NULL,
            created_by TEXT NOT NULL,
            device_id TEXT,
            UNIQUE (encounter_id, sha256)
        )"""
    )
    db.execute("CREATE INDEX assets_encounter ON assets (encounter_id, kind)")


@migrations()
def m005_video_frames(db: Database) -> None:
    db.execute("ALTER TABLE assets ADD COLUMN frames_done_at TEXT")
    db.execute("ALTER TABLE assets ADD COLUMN frames_error TEXT")


@migrations()
def m006_analysis_jobs(db: Database) -> None:
    db.execute(
        """
        CREATE TABLE analysis_jobs (
            id TEXT PRIMARY KEY,
            encounter_id TEXT NOT NULL,
            patient_id TEXT NOT NULL,
            input_digest TEXT NOT NULL,
            request TEXT NOT NULL,
            state TEXT NOT NULL,
            priority INTEGER NOT NULL,
            stage TEXT NOT NULL DEFAULT '',
            fraction REAL NOT NULL DEFAULT 0,
            message TEXT NOT NULL DEFAULT '',
            attempts INTEGER NOT NULL DEFAULT 0,
            max_attempts INTEGER NOT NULL,
            next_attempt_at TEXT NOT NULL,
            lease_owner TEXT,
            lease_expires_at TEXT,
            cancel_requested INTEGER NOT NULL DEFAULT 0,
            error TEXT,
            pictures INTEGER NOT NULL,
            result_status TEXT,
            created_at TEXT NOT NULL,
            created_by TEXT NOT NULL,
            user_id TEXT NOT NULL,
            started_at TEXT,
            finished_at TEXT,
            cleaned_at TEXT
        )"""
    )
    # One live or finished analysis per encounter and input set: asking again returns it, never a second copy.
    db.execute(
        "CREATE UNIQUE INDEX analysis_jobs_once ON analysis_jobs (encounter_id, input_digest)"
        " WHERE state IN ('queued', 'running', 'done')"
    )
    db.execute("CREATE INDEX analysis_jobs_queue ON analysis_jobs (state, priority, created_at)")
    db.execute("CREATE INDEX analysis_jobs_encounter ON analysis_jobs (encounter_id, created_at)")
    db.execute("CREATE INDEX analysis_jobs_patient ON analysis_jobs (patient_id, created_at)")


@migrations()
def m007_sync(db: Database) -> None:
    from sync.storage.peers import PEERS_DDL

    db.execute(PEERS_DDL)
    db.execute(
        """
        CREATE TABLE outbox (
            bundle_id TEXT PRIMARY KEY,
            encounter_id TEXT NOT NULL,
            version INTEGER NOT NULL,
            center_id TEXT NOT NULL,
            content_digest TEXT NOT NULL,
            state TEXT NOT NULL,
            envelope BLOB NOT NULL,
            chunks INTEGER NOT NULL,
            bytes INTEGER NOT NULL,
            sent_chunks INTEGER NOT NULL DEFAULT 0,
            created_at TEXT NOT NULL,
            created_by TEXT NOT NULL,
            attempts INTEGER NOT NULL DEFAULT 0,
            last_error TEXT,
            delivered_at TEXT,
            receipt BLOB,
            UNIQUE (center_id, encounter_id, version)
        )"""
    )
    db.execute("CREATE INDEX outbox_state ON outbox (state, created_at)")
    db.execute("CREATE TABLE sync_state (key TEXT PRIMARY KEY, value TEXT NOT NULL)")


@migrations()
def m008_must_change_password(db: Database) -> None:
    schema.add_must_change_password(db)


@migrations()
def m009_capture_time_and_attempts(db: Database) -> None:
    """When each job's pictures were taken (JSON of schemas.jobs.CaptureTime; NULL for older jobs), and every
    try of a job with how it ended (gateway/jobs/attempts.py, its SQL in gateway/storage/attempts.py)."""
    db.execute("ALTER TABLE analysis_jobs ADD COLUMN captured TEXT")
    db.execute(
        """
        CREATE TABLE analysis_attempts (
            job_id TEXT NOT NULL REFERENCES analysis_jobs (id),
            seq INTEGER NOT NULL,
            attempt INTEGER NOT NULL,
            started_at TEXT NOT NULL,
            resumed_from TEXT NOT NULL DEFAULT '',
            outcome TEXT NOT NULL,
            ended_at TEXT,
            stage TEXT NOT NULL DEFAULT '',
            exit TEXT NOT NULL DEFAULT '',
            reason TEXT NOT NULL DEFAULT '',
            log_tail TEXT NOT NULL DEFAULT '',
            PRIMARY KEY (job_id, seq)
        )"""
    )


@migrations()
def m010_wounds(db: Database) -> None:
    """Pictures and analyses belong to a wound. Each patient with analyses gets one wound holding all of them and
    their encounters' pictures (a versioned record written by the gateway, with its audit entry); nothing else
    changes, and a clinician then splits or corrects it."""
    db.execute("ALTER TABLE assets ADD COLUMN wound_id TEXT")
    db.execute("ALTER TABLE analysis_jobs ADD COLUMN wound_id TEXT")
    db.execute("CREATE INDEX assets_wound ON assets (wound_id)")
    db.execute("CREATE INDEX analysis_jobs_wound ON analysis_jobs (wound_id, created_at)")
    from gateway.storage.wound_upgrade import give_each_patient_a_wound

    give_each_patient_a_wound(db.conn)


@migrations()
def m011_pictures_set_aside(db: Database) -> None:
    """A picture set aside by a person (a blurred or wrong shot): why, by whom and when, as JSON of
    schemas.capture.SetAside; NULL while it counts. Nothing is deleted."""
    db.execute("ALTER TABLE assets ADD COLUMN set_aside TEXT")


@migrations()
def m012_advice_read(db: Database) -> None:
    """Which consultant advice the clinic has read (one row per consultation version, by whom and when): until
    then it is counted on the header, the patient list and the encounter."""
    db.execute(
        """
        CREATE TABLE advice_read (
            consultation_id TEXT NOT NULL,
            version INTEGER NOT NULL,
            read_by TEXT NOT NULL,
            read_at TEXT NOT NULL,
            PRIMARY KEY (consultation_id, version)
        )
        """
    )
    # Advice already there before this version was read on the pages that showed it: not counted as new.
    db.execute(
        "INSERT INTO advice_read (consultation_id, version, read_by, read_at)"
        " SELECT c.id, v.version, 'before the advice count', v.created_at FROM record_heads c"
        " JOIN record_versions v ON v.seq = c.seq WHERE c.kind = 'consultation'"
    )


@migrations()
def m013_pacs_sends(db: Database) -> None:
    """Each send of an encounter to the hospital's PACS (DICOMweb): its state, the study's UID, what the PACS held
    before and why it failed (base/storage/pacs_sends.py). A failed send marks nothing as sent."""
    pacs_sends.create_table(db)
