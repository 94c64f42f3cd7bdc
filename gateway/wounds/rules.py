"""The checks a wound passes before it is stored, and the time of injury it takes from the encounters.

`check_wound` is the record service's check for the kind `wound` (gateway.records.service.RecordCheck): the
composition root hands it in, so a wound written through the API and one pushed by a phone pass the same checks.
"""

from __future__ import annotations

import datetime as dt
import sqlite3

import msgspec

from base.storage import records as store
from gateway.records.validation import bad_field, not_future, require_live
from schemas.base import utcnow
from schemas.config import Config
from schemas.records import RecordKind
from schemas.wound import Wound, WoundState

DATE_SLACK = dt.timedelta(days=1)
"""The gateway's UTC date can be a day away from the bedside's local date."""


def check_wound(conn: sqlite3.Connection, record_id: str, wound: Wound, config: Config) -> tuple[Wound, str]:
    """The wound to store (its time of injury filled in when left out) and its patient's id; raises InvalidInput
    (422) or NotFound (404, no such patient) when it cannot be stored."""
    if wound.id != record_id:
        raise bad_field("$.id", f"id {wound.id} does not match the wound {record_id} in the address")
    require_live(conn, RecordKind.patient, wound.patient_id)
    _check_regions(wound)
    not_future(wound.time_of_injury, "$.time_of_injury", config)
    if wound.time_of_injury is None:
        wound = msgspec.structs.replace(wound, time_of_injury=injury_from_encounters(conn, wound.patient_id))
    _check_state(wound)
    return wound, wound.patient_id


def injury_from_encounters(conn: sqlite3.Connection, patient_id: str) -> dt.datetime | None:
    """The time of injury of the patient's most recent encounter (latest time of arrival, withdrawn ones left out)
    that records one; None when none does."""
    latest: tuple[dt.datetime, dt.datetime] | None = None
    for record in store.list_heads(conn, RecordKind.encounter, parent_id=patient_id, limit=None):
        encounter = record.value()
        if encounter.time_of_injury is None:
            continue
        if latest is None or encounter.time_of_arrival > latest[0]:
            latest = (encounter.time_of_arrival, encounter.time_of_injury)
    return latest[1] if latest else None


def _check_regions(wound: Wound) -> None:
    if not wound.regions:
        raise bad_field("$.regions", "say which Lund-Browder regions the wound covers: at least one")
    seen = set()
    for i, region in enumerate(wound.regions):
        if region in seen:
            raise bad_field(f"$.regions[{i}]", f"the region {region.value} is listed twice: list each region once")
        seen.add(region)


def _check_state(wound: Wound) -> None:
    state, when = wound.state, wound.state_date
    if state is WoundState.open:
        if when is not None:
            raise bad_field(
                "$.state_date", "an open wound has no state date: the date is when it healed, was grafted or closed"
            )
        return
    if when is None:
        raise bad_field(
            "$.state_date", f"a wound whose state is {state.label} needs state_date: the date it reached that state"
        )
    if when > utcnow().date() + DATE_SLACK:
        raise bad_field("$.state_date", f"the state date {when.isoformat()} is in the future")
    injured = wound.time_of_injury
    if injured is not None and when < injured.date() - DATE_SLACK:
        raise bad_field(
            "$.state_date",
            f"the state date {when.isoformat()} is before the time of injury ({injured.date().isoformat()})",
        )
