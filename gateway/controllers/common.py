"""Helpers shared by the controllers: identifiers in paths, ETags, preconditions, record responses."""

from __future__ import annotations

import re
from typing import Annotated

from litestar import Response
from litestar.params import PathParameter

from gateway.services.records import WriteOutcome
from schemas.base import ID_PATTERN
from schemas.errors import InvalidInput, PreconditionRequired
from schemas.export import ecma_pattern
from schemas.records import Record
from schemas.transfer import SITE_ID_PATTERN

# The document shows each pattern in its ECMA-262 form (gateway/openapi.py); validation uses the Python one.
IdPath = Annotated[
    str,
    PathParameter(
        pattern=ID_PATTERN,
        description="A UUID in canonical lower-case form.",
        schema_extra={"pattern": ecma_pattern(ID_PATTERN)},
    ),
]
"""An identifier in a path, matched whole: a malformed one is a 400, never a lookup of a different id."""
SiteIdPath = Annotated[
    str,
    PathParameter(
        pattern=SITE_ID_PATTERN,
        description="A site's name on the wire.",
        schema_extra={"pattern": ecma_pattern(SITE_ID_PATTERN)},
    ),
]

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
