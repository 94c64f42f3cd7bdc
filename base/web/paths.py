"""Identifiers in paths, matched whole: a malformed one is a 400, never a lookup of a different id."""

from __future__ import annotations

from typing import Annotated

from litestar.params import PathParameter

from schemas.base import ID_PATTERN
from schemas.export import ecma_pattern
from schemas.transfer import SITE_ID_PATTERN

# The document shows each pattern in its ECMA-262 form (base/web/openapi.py); validation uses the Python one.
IdPath = Annotated[
    str,
    PathParameter(
        pattern=ID_PATTERN,
        description="A UUID in canonical lower-case form.",
        schema_extra={"pattern": ecma_pattern(ID_PATTERN)},
    ),
]
"""A record's, user's or device's identifier in a path."""
SiteIdPath = Annotated[
    str,
    PathParameter(
        pattern=SITE_ID_PATTERN,
        description="A site's name on the wire.",
        schema_extra={"pattern": ecma_pattern(SITE_ID_PATTERN)},
    ),
]
