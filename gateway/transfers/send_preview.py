"""What a clinician confirms before a case leaves the clinic: to whom, what goes (grouped in words, with sizes)
and whether the patient's consent is recorded.

Telemedicine consent, as teledermatology standards put it: the consent process is recorded (a signature is not
required) and the patient is told what information and images are sent (New Zealand Teledermatology Quality
Standards, standard 3, via DermNet NZ; Practice guidelines for teledermatology in Australia, Abbott et al. 2020,
"patient selection and consent")."""

from __future__ import annotations

from dataclasses import dataclass

from schemas.patient import SharingConsent
from schemas.transfer import SiteIdentity
from sync.bundle import PartData

CONSENT_WORDS = {
    SharingConsent.given: "The patient agreed to the sending",
    SharingConsent.given_by_guardian: "A parent or guardian agreed to the sending",
    SharingConsent.not_possible: "Consent could not be asked: sent on the clinician's judgement",
    SharingConsent.refused: "The patient refused: the case is not sent",
}
MADE_WHEN_SENT = "The PDF report and the wounds' healing, made as the case is sealed"


@dataclass(frozen=True)
class PartGroup:
    label: str
    count: int
    size_bytes: int


@dataclass(frozen=True)
class SendPreview:
    center: SiteIdentity
    groups: list[PartGroup]
    consent: SharingConsent | None

    @property
    def size_bytes(self) -> int:
        return sum(g.size_bytes for g in self.groups)


def _group(name: str) -> str:
    if name == "record.json":
        return "The encounter's record: history, surveys, burn chart, fluids, recommendations"
    if name == "patient.json":
        return "The patient's details"
    if name == "wounds.json":
        return "The patient's wounds"
    if name.startswith("analyses/"):
        return "3D measurements: results, the painted surface, the outlines on each picture"
    if name.startswith("photos/"):
        return "Photos"
    return name


def grouped(parts: list[PartData]) -> list[PartGroup]:
    """The parts in groups a person reads, in the bundle's order; photos and analyses (not their files) counted."""
    sizes: dict[str, int] = {}
    units: dict[str, set[str]] = {}
    for part in parts:
        label = _group(part.name)
        sizes[label] = sizes.get(label, 0) + len(part.data)
        unit = part.name.split("/")[1] if part.name.startswith("analyses/") else part.name
        units.setdefault(label, set()).add(unit)
    return [PartGroup(label, len(units[label]), size) for label, size in sizes.items()]
