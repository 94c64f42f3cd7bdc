"""What the encounter pages show, read once per request through the services: the encounter with its parts, the
calculators' results, the recommendations, the burn center's traffic."""

from __future__ import annotations

from dataclasses import dataclass, field

import msgspec

from base.accounts.permissions import Principal
from base.web.pages.rendering import patient_name
from gateway.dependencies import Services
from schemas.clinical_results import Assessment
from schemas.decision_support import DecisionSupport
from schemas.errors import Forbidden, NotFound
from schemas.records import Record, RecordKind

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
    patient = services.records.get(who, RecordKind.patient, encounter.data["patient_id"])
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
