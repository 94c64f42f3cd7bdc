"""What the encounter pages show, read once per request through the services: the encounter's snapshot (its parts,
the calculators' results, the recommendations, the consultants' advice) and the burn center's traffic."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from base.accounts.permissions import Principal
from base.web.pages.forms_spec import human, struct_fields
from base.web.pages.rendering import patient_name
from gateway.dependencies import Services
from schemas.clinical_results import Assessment
from schemas.decision_support import DecisionSupport
from schemas.encounter_snapshot import EncounterSnapshot
from schemas.errors import Forbidden
from schemas.records import RECORD_TYPES, Record, RecordKind
from schemas.transfer import Consultation, OutboxEntry

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
    RecordKind.intake: "History (allergies, medicines, tetanus)",
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
    """The encounter's overview, made from one reading of its record (schemas/encounter_snapshot.py) and the
    transfers of it to the burn center."""

    snapshot: EncounterSnapshot
    transfers: list[OutboxEntry] = field(default_factory=list)

    @property
    def encounter(self) -> Record:
        return self.snapshot.encounter.record

    @property
    def patient(self) -> Record:
        return self.snapshot.patient.record

    @property
    def patient_name(self) -> str:
        return patient_name(self.patient.data)

    @property
    def parts(self) -> dict[RecordKind, Record]:
        """The parts recorded so far, as stored (their version, who saved them and when)."""
        return {kind: part.record for kind, part in self.snapshot.parts().items()}

    @property
    def assessment(self) -> Assessment | None:
        return self.snapshot.assessment.value if self.snapshot.assessment else None

    @property
    def decision_support(self) -> DecisionSupport | None:
        support = self.snapshot.decision_support
        return support.value if support else None

    @property
    def decision_support_version(self) -> int:
        support = self.snapshot.decision_support
        return support.ref.version if support else 0

    @property
    def consultations(self) -> list[Consultation]:
        return [c.value for c in self.snapshot.consultations]


def encounter_header(services: Services, who: Principal, encounter_id: str) -> tuple[Record, Record]:
    """(encounter, patient): the two every encounter page names in its heading."""
    encounter = services.records.get(who, RecordKind.encounter, encounter_id)
    patient = services.records.get(who, RecordKind.patient, encounter.value().patient_id)
    return encounter, patient


def encounter_view(services: Services, who: Principal, encounter_id: str) -> EncounterView:
    snapshot = services.records.snapshot(who, encounter_id)
    try:
        transfers = services.transfers.transfers(who, encounter_id)
    except Forbidden:
        transfers = []
    return EncounterView(snapshot=snapshot, transfers=transfers)
