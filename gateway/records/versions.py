"""Writing the next version of a record with its audit entry: the one path every record write takes (the record
service's create, update and withdraw, and the merge of two patients' records)."""

from __future__ import annotations

import sqlite3

from base.accounts.permissions import Principal
from base.storage import audit
from base.storage import records as store
from schemas.base import iso
from schemas.records import Record, RecordKind


def write_version(
    conn: sqlite3.Connection,
    principal: Principal,
    kind: RecordKind,
    record_id: str,
    version: int,
    parent_id: str | None,
    data_json: bytes,
    current: Record | None,
    action: str,
    *,
    reason: str | None = None,
    detail: str | None = None,
) -> Record:
    """Store `version` (withdrawn when `reason` is given) and append its audit entry (detail: `detail`, else the
    reason). Inside the caller's write transaction."""
    deleted = reason is not None
    record = store.insert_version(
        conn,
        kind=kind,
        record_id=record_id,
        version=version,
        parent_id=parent_id,
        data_json=data_json,
        created_at=iso(current.meta.created_at) if current else None,
        updated_by=principal.username,
        device_id=principal.device_id,
        deleted=deleted,
        delete_reason=reason,
    )
    audit.append(
        conn,
        action=action,
        user_id=principal.user_id,
        device_id=principal.device_id,
        kind=kind.value,
        record_id=record_id,
        before_version=current.meta.version if current else None,
        after_version=version,
        detail=detail if detail is not None else (reason or ""),
        content_hash=store.version_content_hash(data_json.decode(), deleted, reason),
    )
    return record
