"""Tables both servers keep, created by each server's own migration set (the gateway's m002, m003 and m008; the
center's c001 and c003). Never edit one that has been released: the servers' next migrations change them."""

from __future__ import annotations

from sqlite_utils import Database


def create_accounts(db: Database) -> None:
    """The accounts tables: users, paired devices, pairing codes, sessions and the login throttle."""
    db.execute(
        """
        CREATE TABLE users (
            id TEXT PRIMARY KEY,
            username TEXT NOT NULL UNIQUE,
            password_hash TEXT NOT NULL,
            role TEXT NOT NULL,
            display_name TEXT NOT NULL DEFAULT '',
            active INTEGER NOT NULL DEFAULT 1,
            created_at TEXT NOT NULL
        )"""
    )
    db.execute(
        """
        CREATE TABLE devices (
            id TEXT PRIMARY KEY,
            name TEXT NOT NULL,
            fingerprint TEXT NOT NULL DEFAULT '',
            token_hash TEXT NOT NULL UNIQUE,
            paired_at TEXT NOT NULL,
            paired_by TEXT NOT NULL,
            revoked_at TEXT,
            last_seen_at TEXT
        )"""
    )
    db.execute(
        """
        CREATE TABLE pairing_codes (
            code_hash TEXT PRIMARY KEY,
            device_name TEXT NOT NULL,
            created_by TEXT NOT NULL,
            created_at TEXT NOT NULL,
            expires_at TEXT NOT NULL,
            used_at TEXT
        )"""
    )
    db.execute(
        """
        CREATE TABLE sessions (
            token_hash TEXT PRIMARY KEY,
            user_id TEXT NOT NULL REFERENCES users(id),
            device_id TEXT REFERENCES devices(id),
            created_at TEXT NOT NULL,
            expires_at TEXT NOT NULL,
            revoked_at TEXT
        )"""
    )
    db.execute(
        """
        CREATE TABLE login_throttle (
            key TEXT PRIMARY KEY,
            failures INTEGER NOT NULL,
            last_attempt_at TEXT NOT NULL,
            locked_until TEXT
        ) WITHOUT ROWID"""
    )


def create_audit_log(db: Database) -> None:
    """The hash-chained audit trail (base/storage/audit.py)."""
    db.execute(
        """
        CREATE TABLE audit_log (
            seq INTEGER PRIMARY KEY,
            at TEXT NOT NULL,
            user_id TEXT,
            device_id TEXT,
            action TEXT NOT NULL,
            kind TEXT,
            record_id TEXT,
            before_version INTEGER,
            after_version INTEGER,
            detail TEXT NOT NULL DEFAULT '',
            content_hash TEXT,
            prev_hash TEXT NOT NULL,
            hash TEXT NOT NULL
        )"""
    )


def add_must_change_password(db: Database) -> None:
    """Set by an administrator's password reset; cleared when the user changes the password."""
    db.execute("ALTER TABLE users ADD COLUMN must_change_password INTEGER NOT NULL DEFAULT 0")
