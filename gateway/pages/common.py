"""Helpers shared by the gateway's page controllers: the posted form, writing a record part from it, and the
messages a person reads when a save did not happen."""

from __future__ import annotations

import datetime as dt
import re
from typing import Any

import msgspec

from base.accounts.permissions import WRITE, Principal
from base.web.pages.clinic_time import ClinicClock
from base.web.pages.forms import FormInvalid, field_errors, parse_form, posted_text
from gateway.dependencies import Services
from schemas.base import ID_PATTERN
from schemas.errors import Conflict, InvalidInput, VersionMismatch
from schemas.records import Record, RecordKind


def posted_version(data: dict[str, Any]) -> int:
    """The record version the form was made from (0: the part did not exist yet)."""
    text = posted_text(data, "version").strip()
    if not text.isdigit():
        raise InvalidInput("the form lost its record version: open the page again and repeat your change")
    return int(text)


def posted_id(data: dict[str, Any], name: str = "id") -> str:
    """An identifier the form was given when it was made, so a double submit stores one record, not two."""
    text = posted_text(data, name).strip()
    if re.fullmatch(ID_PATTERN, text) is None:
        raise InvalidInput("the form lost its record id: open the page again and repeat your change")
    return text


def save_part(
    services: Services, who: Principal, kind: RecordKind, record_id: str, body: msgspec.Struct, version: int
) -> Record:
    """Create the part (version 0) or update the version the form was made from; VersionMismatch when someone
    else saved first."""
    if version == 0:
        try:
            return services.records.create(who, kind, record_id, body).record
        except Conflict as exc:
            raise VersionMismatch(exc.detail, current=exc.current) from exc
    return services.records.update(who, kind, record_id, body, version).record


def saved_first(exc: VersionMismatch, clock: ClinicClock | None = None) -> str:
    """What a person reads when someone else saved the same record while they were editing."""
    current = exc.current
    if isinstance(current, Record):
        who = current.meta.updated_by or "someone"
        when = (clock or ClinicClock()).local(current.meta.updated_at).strftime("%H:%M")
        return (
            f"Not saved: {who} saved this at {when} (version {current.meta.version}) while you were editing. "
            "Your entries are kept below; the saved version is shown beside them. Check both, then save again."
        )
    return "Not saved: someone else saved this while you were editing. Open the page again and repeat your change."


def parse_or_errors(
    struct_type: type, data: dict[str, Any], fixed: dict, tz: dt.tzinfo | None = None
) -> tuple[Any, dict[str, str]]:
    """(the Struct, {}) or (None, errors by input name) — the page shows the form again with the errors. Typed
    date-times are wall time in `tz` (the clinic's zone; None: this machine's)."""
    try:
        return parse_form(struct_type, data, fixed=fixed, tz=tz), {}
    except FormInvalid as exc:
        return None, field_errors(exc.errors)


def service_errors(exc: InvalidInput) -> dict[str, str]:
    """A service's refusal as the errors of the form shown again: on their inputs where it names JSON paths
    ("$.time_of_injury"), else about the form as a whole ("")."""
    return field_errors(exc.errors) if exc.errors else {"": exc.detail}


def may_write(who: Principal, kind: RecordKind) -> bool:
    """Whether the page offers a save for this part (the service checks again on the write itself)."""
    return kind in WRITE.get(who.role, frozenset())
