"""What the encounter pages show, read once per request through the services: the encounter with its parts, the
calculators' results, the recommendations, the burn center's traffic."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import msgspec

from base.accounts.permissions import Principal
from base.web.pages.forms_spec import human, struct_fields
from base.web.pages.rendering import patient_name
from gateway.dependencies import Services
from schemas.clinical_results import Assessment
from schemas.decision_support import DecisionSupport
from schemas.errors import Forbidden, NotFound
from schemas.records import RECORD_TYPES, Record, RecordKind

PART_PAGES = {
    "intake": RecordKind.intake,
    "primary-survey": RecordKind.primary_survey,
    "secondary-survey": RecordKind.secondary_survey,
    "mechanism": RecordKind.mechanism,
    "fluids": RecordKind.resuscitation,
}
"""The record parts edited as plain forms (the burn chart has its own page), by their page's slug."""
FORM_PAGES = {**PART_PAGES, "burn-chart": RecordKind.burn_chart}
"""Every part with a form page: the burn chart's is its whole table (special areas, age adjustment)."""
PART_TITLES = {
    RecordKind.intake: "Intake",
    RecordKind.primary_survey: "Primary survey (ABCDE)",
    RecordKind.secondary_survey: "Secondary survey",
    RecordKind.mechanism: "Mechanism",
    RecordKind.resuscitation: "Fluids (formula and fluid given)",
    RecordKind.burn_chart: "Burn chart",
}

OLDER_FIELDS = {RecordKind.intake: ("tetanus_status",)}
"""Fields a newer field replaced on the form: not asked any more, kept as stored, shown read-only where they hold
more than their default (the intake's tetanus summary: the dose count and the last dose replace it)."""


def older_fields(kind: RecordKind) -> frozenset[str]:
    return frozenset(OLDER_FIELDS.get(kind, ()))


def older_values(kind: RecordKind, data: dict | None) -> dict[str, Any]:
    """The older fields' values a save keeps: the stored ones, else their defaults."""
    defaults = {s.name: s.default for s in struct_fields(RECORD_TYPES[kind])}
    return {name: (data or {}).get(name, defaults[name]) for name in OLDER_FIELDS.get(kind, ())}


def older_shown(kind: RecordKind, data: dict | None) -> list[tuple[str, str]]:
    """(label, value) of the older fields a stored record holds beyond their defaults, for reading only."""
    specs = {s.name: s for s in struct_fields(RECORD_TYPES[kind])}
    return [
        (specs[name].label, human(str(value)))
        for name, value in older_values(kind, data).items()
        if str(value) != str(specs[name].default)
    ]


@dataclass
class EncounterView:
    encounter: Record
    patient: Record
    parts: dict[RecordKind, Record]
    assessment: Assessment | None
    decision_support: DecisionSupport | None
    decision_support_version: int = 0
    transfers: list = field(default_factory=list)
    consultations: list[Record] = field(default_factory=list)

    @property
    def patient_name(self) -> str:
        return patient_name(self.patient.data)


def encounter_header(services: Services, who: Principal, encounter_id: str) -> tuple[Record, Record]:
    """(encounter, patient): the two every encounter page names in its heading."""
    encounter = services.records.get(who, RecordKind.encounter, encounter_id)
    patient = services.records.get(who, RecordKind.patient, encounter.value().patient_id)
    return encounter, patient


def encounter_view(services: Services, who: Principal, encounter_id: str) -> EncounterView:
    encounter, patient = encounter_header(services, who, encounter_id)
    record = services.records.encounter_record(who, encounter_id)
    parts = dict(record.parts)
    assessment_record = parts.get(RecordKind.assessment)
    assessment = msgspec.convert(assessment_record.data, Assessment) if assessment_record else None
    support, support_version = None, 0
    try:
        support_record = services.decision_support.get(who, encounter_id)
        support = msgspec.convert(support_record.data, DecisionSupport)
        support_version = support_record.meta.version
    except (NotFound, Forbidden):
        pass
    transfers, consultations = [], []
    try:
        transfers = services.transfers.transfers(who, encounter_id)
        consultations = services.transfers.consultations(who, encounter_id)
    except Forbidden:
        pass
    return EncounterView(
        encounter=encounter,
        patient=patient,
        parts=parts,
        assessment=assessment,
        decision_support=support,
        decision_support_version=support_version,
        transfers=transfers,
        consultations=consultations,
    )
