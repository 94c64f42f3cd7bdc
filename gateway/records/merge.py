"""Merging two records of the same person: the duplicate's encounters and wounds move to the patient kept, each as
a new version (action "record.merge"), and the duplicate is withdrawn with the reason and `merged_into` naming the
patient kept. One write transaction; nothing is deleted, and every step is in the records' history and the audit
trail.

An ordinary update may not move a record to another patient (validation.check_unchanged_links): the merge writes
these versions deliberately, here, and nowhere else."""

from __future__ import annotations

import sqlite3

import msgspec

from base.accounts.permissions import Principal, require_delete, require_write
from base.storage import records as store
from gateway.records.assessments import refresh_assessments
from gateway.records.versions import write_version
from gateway.storage import jobs
from gateway.storage.database import Database
from schemas.config import Config
from schemas.errors import Conflict, InvalidInput, VersionMismatch
from schemas.patient import display_name
from schemas.records import Record, RecordKind

MERGE = "record.merge"
MOVED_KINDS = (RecordKind.encounter, RecordKind.wound)
"""The records of a patient that move with a merge (their encounter parts follow their encounter)."""


class MergeOutcome(msgspec.Struct, frozen=True, kw_only=True):
    kept: Record
    duplicate: Record
    """The duplicate as withdrawn by the merge."""
    encounters: int
    wounds: int


def merge_patients(
    db: Database,
    config: Config,
    principal: Principal,
    keep_id: str,
    duplicate_id: str,
    reason: str,
    duplicate_version: int | None = None,
) -> MergeOutcome:
    """Merge `duplicate_id` into `keep_id`; `duplicate_version`: the version the person looked at (VersionMismatch
    when it changed since). Refuses a merge into itself or into a withdrawn patient, and a role that may not write
    and withdraw patients."""
    for kind in (RecordKind.patient, *MOVED_KINDS):
        require_write(principal, kind)
    require_delete(principal, RecordKind.patient)
    if keep_id == duplicate_id:
        raise InvalidInput("a record cannot be merged into itself: choose the same person's other record")
    if not reason.strip():
        raise InvalidInput("say why the two records are the same person (reason)")
    with db.write() as conn:
        keep, duplicate = _live_pair(conn, keep_id, duplicate_id, duplicate_version)
        moved = {kind: _move(conn, principal, kind, duplicate_id, keep_id, reason) for kind in MOVED_KINDS}
        withdrawn = _withdraw_duplicate(conn, principal, keep, duplicate, reason)
        # The healing track reads the measured visits by patient: the moved encounters' analyses follow them.
        jobs.move_to_patient(conn, [r.meta.id for r in moved[RecordKind.encounter]], keep_id)
        live = [r.meta.id for r in moved[RecordKind.encounter] if not r.meta.deleted]
        refresh_assessments(conn, principal, live, config)
        return MergeOutcome(
            kept=keep,
            duplicate=withdrawn,
            encounters=len(moved[RecordKind.encounter]),
            wounds=len(moved[RecordKind.wound]),
        )


def _live_pair(
    conn: sqlite3.Connection, keep_id: str, duplicate_id: str, duplicate_version: int | None
) -> tuple[Record, Record]:
    keep = store.get_head(conn, RecordKind.patient, keep_id)
    duplicate = store.get_head(conn, RecordKind.patient, duplicate_id)
    if keep.meta.deleted:
        raise Conflict(
            f"{display_name(keep.data)} was withdrawn: restore that record first, or keep the other one",
            current=keep,
        )
    if duplicate.meta.deleted:
        raise Conflict(f"{display_name(duplicate.data)} was already withdrawn: nothing to merge", current=duplicate)
    if duplicate_version is not None and duplicate.meta.version != duplicate_version:
        raise VersionMismatch(
            f"{display_name(duplicate.data)} was changed while you were comparing (now version"
            f" {duplicate.meta.version}): compare the two records again",
            current=duplicate,
        )
    return keep, duplicate


def _move(
    conn: sqlite3.Connection, principal: Principal, kind: RecordKind, from_id: str, to_id: str, reason: str
) -> list[Record]:
    """Every record of `kind` of the duplicate (withdrawn ones too, still withdrawn) as a new version under `to_id`."""
    moved = []
    for record in store.list_heads(conn, kind, parent_id=from_id, include_deleted=True, limit=None):
        data = msgspec.json.encode({**record.data, "patient_id": to_id})
        withdrawn = record.meta.delete_reason if record.meta.deleted else None
        moved.append(
            write_version(
                conn,
                principal,
                kind,
                record.meta.id,
                record.meta.version + 1,
                to_id,
                data,
                record,
                MERGE,
                reason=withdrawn,
                detail=f"moved from patient {from_id} to patient {to_id}: {reason}",
            )
        )
    return moved


def _withdraw_duplicate(
    conn: sqlite3.Connection, principal: Principal, keep: Record, duplicate: Record, reason: str
) -> Record:
    data = msgspec.json.encode({**duplicate.data, "merged_into": keep.meta.id})
    return write_version(
        conn,
        principal,
        RecordKind.patient,
        duplicate.meta.id,
        duplicate.meta.version + 1,
        None,
        data,
        duplicate,
        MERGE,
        reason=f"merged into {display_name(keep.data)} ({keep.meta.id}): {reason.strip()}",
    )
