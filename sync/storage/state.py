"""The sync_state table: the clinic's round and backoff values, and a cursor into each center's mailbox, as text
under a key."""

from __future__ import annotations

import sqlite3
from collections.abc import Iterable, Mapping

import msgspec

from schemas.transfer import LinkSettings, SyncRoundState

_MAIL_CURSOR = "mail_after:"
"""Prefix of the keys that hold, per center, the last mailbox message stored; the other keys are the rounds'."""
_LINK = "link_settings"
"""The key of the link as set on the Burn center page (a LinkSettings in JSON)."""


def round_state(conn: sqlite3.Connection) -> SyncRoundState:
    rows = conn.execute(
        "SELECT key, value FROM sync_state WHERE key NOT LIKE ? AND key <> ?", (f"{_MAIL_CURSOR}%", _LINK)
    )
    values = {r["key"]: r["value"] for r in rows}
    return SyncRoundState(
        last_round_at=values.get("last_round_at"),
        last_success_at=values.get("last_success_at"),
        last_error=values.get("last_error"),
        next_round_at=values.get("next_round_at"),
        failures=int(values.get("failures", 0)),
        audit_anchor_problem=values.get("audit_anchor_problem"),
    )


def put_round_values(conn: sqlite3.Connection, values: Mapping[str, str], clear: Iterable[str] = ()) -> None:
    """Set the round values given (by SyncRoundState field name) and remove those in `clear`."""
    conn.executemany(
        "INSERT INTO sync_state (key, value) VALUES (?, ?) ON CONFLICT (key) DO UPDATE SET value = excluded.value",
        list(values.items()),
    )
    conn.executemany("DELETE FROM sync_state WHERE key = ?", [(k,) for k in clear])


def mail_cursor(conn: sqlite3.Connection, center_id: str) -> int:
    """The sequence number of the last message stored from that center's mailbox; 0 before the first."""
    row = conn.execute("SELECT value FROM sync_state WHERE key = ?", (f"{_MAIL_CURSOR}{center_id}",)).fetchone()
    return int(row["value"]) if row else 0


def advance_mail_cursor(conn: sqlite3.Connection, center_id: str, seq: int) -> None:
    """Move the center's cursor on to `seq`; never back."""
    conn.execute(
        "INSERT INTO sync_state (key, value) VALUES (?, ?) ON CONFLICT (key) DO UPDATE SET value ="
        " MAX(CAST(value AS INTEGER), CAST(excluded.value AS INTEGER))",
        (f"{_MAIL_CURSOR}{center_id}", str(seq)),
    )


def link_settings(conn: sqlite3.Connection) -> LinkSettings | None:
    """The link as last set on the Burn center page; None while it was never set there."""
    row = conn.execute("SELECT value FROM sync_state WHERE key = ?", (_LINK,)).fetchone()
    return msgspec.json.decode(row["value"], type=LinkSettings) if row else None


def put_link_settings(conn: sqlite3.Connection, settings: LinkSettings) -> None:
    conn.execute(
        "INSERT INTO sync_state (key, value) VALUES (?, ?) ON CONFLICT (key) DO UPDATE SET value = excluded.value",
        (_LINK, msgspec.json.encode(settings).decode()),
    )
