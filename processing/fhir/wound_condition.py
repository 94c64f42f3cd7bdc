"""Each wound of the patient as a FHIR R4 Condition: a burn (SNOMED CT 125666000) at its body sites, active until
it heals, is grafted or is closed another way (then resolved, with the date as abatement). Each WoundSize panel of
the wound names it as its `focus` (R4 Observation.focus: what the observation is about, when that is not the
subject of record), so a receiver can follow one wound across visits."""

from __future__ import annotations

from processing.fhir import codes
from processing.fhir.codes import concept
from processing.fhir.record import iso, record_identifier, resource_id, version_meta
from schemas.encounter_snapshot import Versioned
from schemas.wound import Wound, WoundState

_SIDE_WORDS = {"left": "left", "right": "right", "midline": "midline", "bilateral": "both sides"}


def wound_conditions(wounds: list[Versioned[Wound]], subject: dict) -> dict[str, dict]:
    """By wound id, the wound's Condition."""
    return {w.value.id: _condition(w, subject) for w in wounds}


def _condition(versioned: Versioned[Wound], subject: dict) -> dict:
    wound = versioned.value
    closed = wound.state not in (WoundState.open, WoundState.healing)
    status = ("resolved", "Resolved") if closed else ("active", "Active")
    text = wound.label + (f" ({_SIDE_WORDS[wound.side.value]})" if wound.side else "")
    notes = [f"Wound state: {wound.state.label}" + (f" on {wound.state_date.isoformat()}" if wound.state_date else "")]
    if wound.site_detail:
        notes.append(f"Site: {wound.site_detail}")
    if wound.cause is not None:
        notes.append(f"Cause: {wound.cause.value}")
    if wound.notes:
        notes.append(wound.notes)
    out = {
        "resourceType": "Condition",
        "id": resource_id("wound", wound.id, str(versioned.ref.version)),
        "meta": version_meta(versioned),
        "identifier": [record_identifier("wound", wound.id)],
        "clinicalStatus": concept((codes.CONDITION_CLINICAL, *status)),
        "verificationStatus": concept((codes.CONDITION_VERIFICATION, "confirmed", "Confirmed")),
        "category": [concept((codes.CONDITION_CATEGORY, "problem-list-item", "Problem List Item"))],
        "code": concept(codes.BURN, text=f"Burn: {text}"),
        "bodySite": [codes.body_site(region) for region in wound.regions],
        "subject": subject,
        "note": [{"text": n} for n in notes],
    }
    if wound.time_of_injury is not None:
        out["onsetDateTime"] = iso(wound.time_of_injury)
    if closed and wound.state_date is not None:
        out["abatementDateTime"] = wound.state_date.isoformat()
    return out
