"""Shared building blocks: the base Struct, identifiers, timestamps and bounded numbers."""

from __future__ import annotations

import datetime as dt
from typing import Annotated

import msgspec

# Identifiers: a UUID in canonical text form, lower case, nothing around it (UUIDv7 preferred, any version
# accepted so existing phone libraries work). msgspec searches patterns, so the pattern is anchored at both
# ends with \A and \Z: `$` would also match before a final newline, making "<uuid>\n" a second, different id.
ID_PATTERN = r"\A[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}\Z"
Id = Annotated[
    str,
    msgspec.Meta(
        pattern=ID_PATTERN,
        description="Identifier: a UUID in canonical lower-case form (v7 preferred), nothing before or after it.",
        examples=["0192f3b4-6a8e-7c3d-9b1a-2f4e5d6c7b8a"],
    ),
]
# Timestamps must carry a UTC offset: a clinical time without one is ambiguous.
Timestamp = Annotated[dt.datetime, msgspec.Meta(tz=True, description="ISO 8601 with offset.")]
# Physiological limits: the schemas and the calculators both enforce these.
WEIGHT_MAX_KG = 400.0
HEIGHT_MIN_CM = 20.0
HEIGHT_MAX_CM = 272.0
AGE_MAX_YEARS = 130.0

ShortText = Annotated[str, msgspec.Meta(max_length=200)]
LongText = Annotated[str, msgspec.Meta(max_length=20_000)]
Fraction = Annotated[float, msgspec.Meta(ge=0.0, le=1.0, description="0 to 1.")]
Percent = Annotated[float, msgspec.Meta(ge=0.0, le=100.0)]
WeightKg = Annotated[float, msgspec.Meta(gt=0.0, le=WEIGHT_MAX_KG, description="Body weight in kg.")]
HeightCm = Annotated[float, msgspec.Meta(ge=HEIGHT_MIN_CM, le=HEIGHT_MAX_CM, description="Body height in cm.")]
Millilitres = Annotated[float, msgspec.Meta(ge=0.0, le=100_000.0)]


class Message(msgspec.Struct, kw_only=True, forbid_unknown_fields=True, omit_defaults=False):
    """Base of every message: unknown fields are an error, never silently dropped."""


class Frozen(Message, frozen=True):
    """Immutable message (results and envelopes)."""


def utcnow() -> dt.datetime:
    return dt.datetime.now(dt.UTC)


def iso(t: dt.datetime) -> str:
    """The one text form of a stored timestamp: ISO 8601, microseconds, with offset."""
    return t.isoformat(timespec="microseconds")


def counted(n: int, noun: str, plural: str | None = None) -> str:
    """ "1 photo", "2 photos": a count with its noun in the number people read ("1 photo(s)" reads as a fault)."""
    return f"{n} {noun if n == 1 else plural or noun + 's'}"
