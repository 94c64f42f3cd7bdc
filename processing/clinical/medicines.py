"""Recorded medicines that change a burn decision, matched by name as the intake recorded them.

Only anticoagulants are recognised: they matter to escharotomy and any other surgery on the burn (bleeding). The
names are the generic names of the oral anticoagulants and heparins in the sources below, with the common brand
names printed on packs; a medicine recorded under another name is not recognised, and the recommendation says
that the list was checked, not that the patient takes no anticoagulant.
"""

from __future__ import annotations

from processing.clinical.decision_inputs import DecisionInputs
from schemas.decision_support import InputUsed, Source

ANTICOAGULANT_SOURCE = Source(
    guideline="Patient.info Professional: Oral anticoagulants (2021); eTG complete: Practical information on using "
    "low molecular weight heparin",
    year=2021,
    section="The oral anticoagulants available in the UK; low molecular weight heparins (enoxaparin, dalteparin)",
    url="https://patient.info/doctor/oral-anticoagulants",
    accessed="2026-12-06",
)
ANTICOAGULANTS = (
    "warfarin",
    "coumadin",
    "acenocoumarol",
    "phenindione",
    "dabigatran",
    "pradaxa",
    "rivaroxaban",
    "xarelto",
    "apixaban",
    "eliquis",
    "edoxaban",
    "lixiana",
    "savaysa",
    "heparin",
    "enoxaparin",
    "clexane",
    "lovenox",
    "dalteparin",
    "fragmin",
    "tinzaparin",
    "innohep",
)


def anticoagulants(inputs: DecisionInputs) -> list[InputUsed]:
    """The recorded medicines whose names are anticoagulants, each as a fact read from the intake."""
    if inputs.intake is None:
        return []
    found = []
    for medicine in inputs.intake.value.medications:
        name = medicine.name.lower()
        if any(known in name for known in ANTICOAGULANTS):
            shown = medicine.name + (f" {medicine.dose}" if medicine.dose else "")
            found.append(inputs.intake.used("anticoagulant recorded", shown))
    return found
