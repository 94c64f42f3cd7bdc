"""The intake's allergies, current medications and tetanus history as FHIR R4: one AllergyIntolerance per allergy
(or the conventional "no known allergy" one), one MedicationStatement per medicine, and the tetanus history as an
Observation. Plain dicts in FHIR JSON; bundle.py validates them.

Only what the clinician recorded is exported: a substance and a medicine are given as text (code.text), as
written, with no code or drug class looked up. Nothing is exported for what the record does not hold.
"""

from __future__ import annotations

from processing.fhir import codes
from processing.fhir.codes import concept
from processing.fhir.record import iso, resource_id, version_meta
from processing.report.history_text import tetanus_lines, tetanus_recorded
from schemas.encounter_snapshot import Versioned
from schemas.patient import Encounter
from schemas.record_parts import Intake, TetanusStatus

FROM_HISTORY = "Recorded at the clinic's intake from the history (patient or family); not tested."


def _key(intake: Versioned[Intake], *parts: str) -> str:
    return "|".join((intake.ref.id, str(intake.ref.version), *parts))


def allergies(intake: Versioned[Intake] | None, subject: dict, enc: dict) -> list[dict]:
    """One AllergyIntolerance per recorded allergy; the "no known allergy" one when the clinician said so and
    listed none; nothing when allergies were not recorded."""
    if intake is None:
        return []
    active = concept((codes.ALLERGY_CLINICAL, "active", "Active"))
    common = {"resourceType": "AllergyIntolerance", "meta": version_meta(intake), "clinicalStatus": active}
    common |= {"patient": subject, "encounter": enc}
    listed = intake.value.allergies
    if not listed and intake.value.no_known_allergies:
        return [
            {
                **common,
                "id": resource_id("allergy", _key(intake, "none-known")),
                "verificationStatus": concept((codes.ALLERGY_VERIFICATION, "confirmed", "Confirmed")),
                "code": concept(codes.NO_KNOWN_ALLERGY, text="No known allergies"),
                "note": [{"text": "The clinician recorded no known allergies at intake."}],
            }
        ]
    out = []
    for index, allergy in enumerate(listed):
        resource = {
            **common,
            "id": resource_id("allergy", _key(intake, str(index), allergy.substance)),
            "code": {"text": allergy.substance},
            "note": [{"text": FROM_HISTORY + ("" if allergy.reaction else " Reaction not recorded.")}],
        }
        if allergy.reaction:
            resource["reaction"] = [{"manifestation": [{"text": allergy.reaction}]}]
        out.append(resource)
    return out


def medications(intake: Versioned[Intake] | None, subject: dict, enc: dict) -> list[dict]:
    """One MedicationStatement per medicine the intake lists as taken, named and dosed as recorded."""
    if intake is None:
        return []
    out = []
    for index, medicine in enumerate(intake.value.medications):
        resource = {
            "resourceType": "MedicationStatement",
            "id": resource_id("medication-statement", _key(intake, str(index), medicine.name)),
            "meta": version_meta(intake),
            "status": "active",
            "medicationCodeableConcept": {"text": medicine.name},
            "subject": subject,
            "context": enc,
            "note": [
                {
                    "text": "Current medication as recorded at the clinic's intake."
                    + ("" if medicine.dose else " Dose not recorded.")
                }
            ],
        }
        if medicine.dose:
            resource["dosage"] = [{"text": medicine.dose}]
        out.append(resource)
    return out


def tetanus(intake: Versioned[Intake] | None, encounter: Versioned[Encounter], subject: dict, enc: dict) -> list[dict]:
    """The tetanus history as the report prints it, in one Observation, dated at the encounter's arrival (the intake
    is taken then); none when nothing is recorded. Not Immunization resources: the record holds a count of prior
    doses and the time since the last, not each dose with its vaccine and date."""
    if intake is None:
        return []
    older_only = not tetanus_recorded(intake.value)
    if older_only and intake.value.tetanus_status is TetanusStatus.unknown:
        return []
    resource = {
        "resourceType": "Observation",
        "id": resource_id("observation", _key(intake, "tetanus")),
        "meta": version_meta(intake),
        "status": "final",
        "code": concept(codes.TETANUS_HISTORY),
        "subject": subject,
        "encounter": enc,
        "effectiveDateTime": iso(encounter.value.time_of_arrival),
        "valueString": "; ".join(tetanus_lines(intake.value)),
        "note": [
            {
                "text": "Prior doses of tetanus-toxoid-containing vaccine as told at intake; not checked against a vaccination record."
            }
        ],
    }
    return [resource]
