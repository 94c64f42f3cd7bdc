"""The clinical record as FHIR R4 resources: Patient, Encounter, the burns (Condition), %TBSA and body size
(Observation), and the consultants' advice (Communication). Plain dicts in FHIR JSON; bundle.py validates them."""

from __future__ import annotations

import datetime as dt
import uuid

from processing.fhir import codes
from processing.fhir.codes import coding, concept
from schemas.burn_chart import BurnChart
from schemas.clinical_results import Assessment
from schemas.encounter_snapshot import Versioned
from schemas.patient import Encounter, Patient
from schemas.transfer import Consultation

NAMESPACE = uuid.UUID("5b0c3f8e-4a51-5d0b-9a57-1f3c0e0b6d21")
"""Every resource id is a UUIDv5 under this, of its kind and what it is made of: the same record versions export
to the same ids, and a patient and an encounter that happen to share a record id still get two (the record id
itself is the resource's identifier)."""
PROVISIONAL_HOURS = 72.0


def iso(moment: dt.datetime | str) -> str:
    """An instant as FHIR writes it: ISO 8601 in UTC (FHIR allows offsets up to 14 h only; the records accept
    any offset ISO 8601 does)."""
    if isinstance(moment, str):
        try:
            moment = dt.datetime.fromisoformat(moment)
        except ValueError:
            return moment
        if moment.tzinfo is None:
            return moment.isoformat()
    return moment.astimezone(dt.UTC).isoformat()


def resource_id(*parts: str) -> str:
    return str(uuid.uuid5(NAMESPACE, "|".join(parts)))


def ref(resource: dict) -> dict:
    return {"reference": f"urn:uuid:{resource['id']}"}


def record_identifier(kind: str, record_id: str) -> dict:
    """A record's stable identifier (its version goes in meta.versionId)."""
    return {"system": f"{codes.LOCAL_ID}/{kind}", "value": record_id}


def version_meta(record: Versioned) -> dict:
    return {"versionId": str(record.ref.version)}


def patient(record: Versioned[Patient]) -> dict:
    p = record.value
    out: dict = {
        "resourceType": "Patient",
        "id": resource_id("patient", p.id),
        "meta": version_meta(record),
        "identifier": [record_identifier("patient", p.id)],
        "gender": codes.GENDER[p.sex],
    }
    if p.medical_record_number:
        mrn = concept(("http://terminology.hl7.org/CodeSystem/v2-0203", "MR", "Medical record number"))
        out["identifier"].append({"type": mrn, "system": f"{codes.LOCAL_ID}/mrn", "value": p.medical_record_number})
    name = {k: v for k, v in (("family", p.family_name), ("given", [p.given_name] if p.given_name else None)) if v}
    if name:
        out["name"] = [{"use": "official", **name}]
    elif p.temporary_label:  # an unknown patient: FHIR's "temp" name use, the label as text
        out["name"] = [{"use": "temp", "text": p.temporary_label}]
    if p.date_of_birth:
        out["birthDate"] = p.date_of_birth.isoformat()
    if p.merged_into:  # a duplicate merged into the same person's other record
        out["active"] = False
        out["link"] = [{"other": {"identifier": record_identifier("patient", p.merged_into)}, "type": "replaced-by"}]
    return out


def encounter(record: Versioned[Encounter], subject: dict, conditions: list[dict]) -> dict:
    e = record.value
    out = {
        "resourceType": "Encounter",
        "id": resource_id("encounter", e.id),
        "meta": version_meta(record),
        "identifier": [record_identifier("encounter", e.id)],
        "status": "unknown",  # burnedge records the arrival, not the discharge
        "class": coding(codes.ENCOUNTER_CLASS[e.mode]),
        "subject": subject,
        "period": {"start": iso(e.time_of_arrival)},
        "reasonCode": [concept(codes.BURN, text="Burn injury")],
    }
    if conditions:
        out["reasonReference"] = [ref(c) for c in conditions]
    if e.facility:
        out["serviceProvider"] = {"display": e.facility}
    return out


def _depth_status(chart: BurnChart, injured: dt.datetime | None) -> str:
    """Burn depth evolves over the first days: an estimate charted before 72 h, or with no injury time, is
    provisional."""
    if injured is None:
        return "provisional"
    hours = (chart.assessed_at - injured).total_seconds() / 3600
    return "provisional" if hours < PROVISIONAL_HOURS else "confirmed"


def conditions(chart: Versioned[BurnChart] | None, enc: Versioned[Encounter], subject: dict) -> list[dict]:
    """One Condition per charted region: the clinician's depth category at that body site."""
    if chart is None:
        return []
    injured = enc.value.time_of_injury
    status = _depth_status(chart.value, injured)
    out = []
    for entry in chart.value.entries:
        site = codes.body_site(entry.region)
        depth = codes.DEPTH_TEXT[entry.depth]
        local = (codes.LOCAL_DEPTH, entry.depth.value, depth)
        condition = {
            "resourceType": "Condition",
            "id": resource_id("condition", chart.ref.id, str(chart.ref.version), entry.region.value, entry.depth.value),
            "meta": version_meta(chart),
            "identifier": [
                record_identifier("burn-chart-entry", f"{chart.ref.id}/{entry.region.value}/{entry.depth.value}")
            ],
            "clinicalStatus": concept((codes.CONDITION_CLINICAL, "active", "Active")),
            "verificationStatus": concept((codes.CONDITION_VERIFICATION, status, status.capitalize())),
            "category": [concept((codes.CONDITION_CATEGORY, "encounter-diagnosis", "Encounter Diagnosis"))],
            "code": concept(codes.DEPTH_SNOMED[entry.depth], local, text=f"{depth}, {site['text']}"),
            "bodySite": [site],
            "subject": subject,
            "encounter": {"reference": f"urn:uuid:{resource_id('encounter', enc.value.id)}"},
            "recordedDate": iso(chart.value.assessed_at),
            "note": [
                {
                    "text": f"{entry.fraction:g} of the region charted as {depth.lower()} by the clinician"
                    + (", circumferential" if entry.circumferential else "")
                    + (
                        ". Depth is a clinical judgement; burns evolve over the first 72 h."
                        if status == "provisional"
                        else "."
                    )
                }
            ],
        }
        if injured:
            condition["onsetDateTime"] = iso(injured)
        out.append(condition)
    return out


def _observation(key: str, code: tuple, subject: dict, enc: dict, when: dt.datetime | str, category: str) -> dict:
    return {
        "resourceType": "Observation",
        "id": resource_id("observation", key),
        "status": "final",
        "category": [concept((codes.OBSERVATION_CATEGORY, category, category.replace("-", " ").title()))],
        "code": concept(code),
        "subject": subject,
        "encounter": enc,
        "effectiveDateTime": iso(when),
    }


def quantity(value: float, unit: str, decimals: int = 2) -> dict:
    return {"value": round(value, decimals), "unit": unit, "system": codes.UCUM, "code": unit}


def assessment_observations(
    record: Versioned[Assessment] | None,
    chart: Versioned[BurnChart] | None,
    encounter_record: Versioned[Encounter],
    subject: dict,
    enc: dict,
) -> list[dict]:
    """%TBSA (Lund-Browder), dated when the chart was drawn; body surface area with the weight and height it was
    computed from, dated at the encounter; each with the calculator's caveats."""
    if record is None:
        return []
    a, key = record.value, f"{record.ref.id}/v{record.ref.version}"
    caveats = [{"text": c} for c in (*a.provenance, *a.caveats)]
    out = []
    if a.tbsa is not None:
        charted = chart.value.assessed_at if chart else a.as_of
        tbsa = _observation(f"{key}/tbsa", codes.TBSA_BURNED, subject, enc, charted, "exam")
        tbsa["valueQuantity"] = quantity(a.tbsa.tbsa_percent, "%", 1)
        tbsa["method"] = {"text": f"{a.tbsa.method} chart ({a.tbsa.age_adjustment}), superficial burns excluded"}
        tbsa["component"] = [
            {"code": concept(codes.TBSA_PARTIAL), "valueQuantity": quantity(a.tbsa.partial_thickness_percent, "%", 1)},
            {"code": concept(codes.TBSA_FULL), "valueQuantity": quantity(a.tbsa.full_thickness_percent, "%", 1)},
        ]
        out.append(tbsa)
    if a.bsa is not None:
        for name, code, value, unit in (
            ("bsa", codes.BODY_SURFACE_AREA, a.bsa.bsa_m2, "m2"),
            ("weight", codes.BODY_WEIGHT, a.bsa.weight_kg, "kg"),
            ("height", codes.BODY_HEIGHT, a.bsa.height_cm, "cm"),
        ):
            when = encounter_record.value.time_of_arrival
            obs = _observation(f"{key}/{name}", code, subject, enc, when, "vital-signs")
            obs["valueQuantity"] = quantity(value, unit)
            if name == "bsa":
                obs["method"] = {"text": a.bsa.method}
            out.append(obs)
    for obs in out:
        obs["issued"] = iso(a.computed_at)
        if caveats:
            obs["note"] = caveats
    return out


def communications(consultations: list[Versioned[Consultation]], subject: dict, enc: dict) -> list[dict]:
    """Each consultant's advice received, as the clinic stored it."""
    out = []
    for record in consultations:
        note = record.value.note
        out.append(
            {
                "resourceType": "Communication",
                "id": resource_id("communication", note.note_id),
                "identifier": [{"system": f"{codes.LOCAL_ID}/consultation-note", "value": note.note_id}],
                "status": "completed",
                "subject": subject,
                "encounter": enc,
                "sent": iso(note.written_at),
                "received": iso(record.value.received_at),
                "sender": {"display": f"{note.consultant} ({note.center_id})"},
                "payload": [
                    {"contentString": text}
                    for text in (f"Recommendation: {note.recommendation.value}. {note.advice}", note.notice)
                    if text.strip()
                ],
            }
        )
    return out
