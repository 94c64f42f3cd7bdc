"""Helpers shared by the gateway's controllers: ETags, preconditions, record responses (identifiers in paths:
base/web/paths.py)."""

from __future__ import annotations

import re

from litestar import Response

from gateway.records.service import WriteOutcome
from schemas.errors import InvalidInput, PreconditionRequired
from schemas.records import Record

_ETAG = re.compile(r'^\s*(?:W/)?"?(\d+)"?\s*$')


def etag(record: Record) -> str:
    return f'"{record.meta.version}"'


def parse_version(header: str | None, *, action: str) -> int:
    """The version from an If-Match header ("3", W/"3" or 3)."""
    if header is None:
        raise PreconditionRequired(
            f"{action} needs If-Match with the version you edited (the ETag from your last read)"
        )
    match = _ETAG.match(header)
    if match is None:
        raise InvalidInput(f'If-Match {header!r} is not a record version: send the ETag you received, e.g. "3"')
    return int(match.group(1))


def record_response(record: Record, status_code: int = 200) -> Response[Record]:
    return Response(content=record, status_code=status_code, headers={"ETag": etag(record)})


def outcome_response(outcome: WriteOutcome) -> Response[Record]:
    return record_response(outcome.record, 201 if outcome.created else 200)
