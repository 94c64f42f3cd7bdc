"""Storing a record the gateway computes (calculator results, decision support): the next version and its audit
entry, inside the caller's transaction."""

from __future__ import annotations

import sqlite3

import msgspec

from base.accounts.permissions import Principal
from base.storage import audit
from base.storage import records as store
from schemas.base import iso
from schemas.records import Record, RecordKind


def store_computed(
    conn: sqlite3.Connection,
    principal: Principal | None,
    kind: RecordKind,
    encounter_id: str,
    data: msgspec.Struct,
    current: Record | None,
    action: str,
    detail: str = "",
) -> Record:
    """`data` as the next version of the encounter's `kind` record (principal None: the gateway itself)."""
    version = current.meta.version + 1 if current else 1
    data_json = msgspec.json.encode(data)
    record = store.insert_version(
        conn,
        kind=kind,
        record_id=encounter_id,
        version=version,
        parent_id=encounter_id,
        data_json=data_json,
        created_at=iso(current.meta.created_at) if current else None,
        updated_by=principal.username if principal else audit.SERVER_USER,
        device_id=principal.device_id if principal else None,
    )
    audit.append(
        conn,
        action=action,
        user_id=principal.user_id if principal else None,
        device_id=principal.device_id if principal else None,
        kind=kind.value,
        record_id=encounter_id,
        before_version=current.meta.version if current else None,
        after_version=version,
        detail=detail,
        content_hash=store.version_content_hash(data_json.decode(), False, None),
    )
    return record
