"""The encounter's telemedicine consent (sending the record and pictures to a burn center for advice) as a FHIR R4
Consent: a privacy consent (scope patient-privacy, category LOINC 59284-0 "Patient Consent"), permitting or
denying disclosure to the burn center for the patient's treatment.

Only a choice the patient (or their guardian) made becomes a Consent. "Could not be asked" is not a consent: it
stays in the encounter's record (`sharing_consent`) and no Consent resource is made for it; neither is one made
while nothing was recorded.
"""

from __future__ import annotations

from processing.fhir.codes import concept
from processing.fhir.record import iso, record_identifier, resource_id, version_meta
from schemas.encounter_snapshot import Versioned
from schemas.patient import Encounter, SharingConsent

SCOPE = ("http://terminology.hl7.org/CodeSystem/consentscope", "patient-privacy", "Privacy Consent")
CATEGORY = ("http://loinc.org", "59284-0", "Patient Consent")
DISCLOSE = ("http://terminology.hl7.org/CodeSystem/consentaction", "disclose", "Disclose")
TREATMENT = ("http://terminology.hl7.org/CodeSystem/v3-ActReason", "TREAT", "treatment")
BY_WHOM = {
    SharingConsent.given: "the patient",
    SharingConsent.given_by_guardian: "a parent, guardian or the person legally able to agree",
    SharingConsent.refused: "the patient",
}
POLICY = (
    "Telemedicine consent as recorded by the treating clinician in burnedge: what is sent (the record, the "
    "pictures, the 3D measurements and the report) and to whom (the linked burn center), for advice on treatment."
)


def consent(record: Versioned[Encounter], subject: dict) -> dict | None:
    """The Consent of the encounter's sharing choice; None when no choice by the patient or guardian is recorded."""
    e = record.value
    choice = e.sharing_consent
    if choice not in BY_WHOM:
        return None
    stored = record.stored
    out = {
        "resourceType": "Consent",
        "id": resource_id("consent", e.id),
        "meta": version_meta(record),
        "identifier": [record_identifier("encounter-consent", e.id)],
        "status": "active",
        "scope": concept(SCOPE),
        "category": [concept(CATEGORY)],
        "patient": subject,
        "performer": [{"display": BY_WHOM[choice]}],
        "policyRule": {"text": POLICY},
        "provision": {
            "type": "deny" if choice is SharingConsent.refused else "permit",
            "action": [concept(DISCLOSE)],
            "purpose": [{"system": TREATMENT[0], "code": TREATMENT[1], "display": TREATMENT[2]}],
        },
    }
    if stored is not None:
        out["dateTime"] = iso(stored.meta.updated_at)
    return out
