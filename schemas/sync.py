"""Phone sync: the change feed (pull) and batched, idempotent mutations (push)."""

from __future__ import annotations

import enum
from typing import Annotated

import msgspec

from schemas.base import Frozen, Id, Message, ShortText, Timestamp
from schemas.records import Record, RecordKind


class MutationOp(enum.StrEnum):
    create = "create"
    update = "update"
    delete = "delete"


class Mutation(Message):
    """One change a phone made while offline, replayable any number of times."""

    mutation_id: Id
    """Client-generated; the gateway applies each mutation_id at most once."""
    kind: RecordKind
    id: Id
    op: MutationOp
    base_version: Annotated[int, msgspec.Meta(ge=1)] | None = None
    """The version the phone edited (update and delete); a mismatch is a conflict."""
    data: dict | None = None
    """The full record (create and update)."""
    reason: ShortText | None = None
    """Why (delete)."""
    client_time: Timestamp | None = None


class PushRequest(Message):
    mutations: Annotated[list[Mutation], msgspec.Meta(max_length=1000)]


class MutationStatus(enum.StrEnum):
    applied = "applied"
    conflict = "conflict"
    rejected = "rejected"


class MutationResult(Frozen):
    mutation_id: Id
    status: MutationStatus
    replayed: bool = False
    """True when this mutation_id was seen before; the stored outcome is returned unchanged."""
    version: int | None = None
    """The version the mutation wrote (applied)."""
    current: Record | None = None
    """The gateway's current record (conflict), so the phone can merge and retry."""
    error: str | None = None


class PushResponse(Frozen):
    results: list[MutationResult]
    applied: int
    conflicts: int
    rejected: int


class ChangesPage(Frozen):
    """Record versions after a cursor, oldest first. Pass next_cursor back to continue."""

    changes: list[Record]
    next_cursor: int
    has_more: bool
