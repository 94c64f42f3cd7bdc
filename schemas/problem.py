"""RFC 9457 problem details, the body of every error response."""

from __future__ import annotations

from typing import Any

from schemas.base import Frozen


class FieldProblem(Frozen):
    field: str
    """Dotted path of the offending field, e.g. "$.entries[2].fraction"."""
    message: str


class Problem(Frozen, omit_defaults=True):
    type: str
    title: str
    status: int
    detail: str
    instance: str | None = None
    errors: list[FieldProblem] = []
    current: Any = None
    """On a version conflict: the current record, so the client can merge."""
