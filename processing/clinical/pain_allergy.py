"""A recorded allergy that blocks a drug, matched by the drug's names in the allergy's substance."""

from __future__ import annotations

from processing.clinical.decision_inputs import DecisionInputs
from schemas.decision_support import InputUsed

NAMES = {
    "paracetamol": ("paracetamol", "acetaminophen"),
    "fentanyl": ("fentanyl", "opiate", "opioid"),
    "morphine": ("morphine", "opiate", "opioid"),
}
"""A drug's names; an allergy recorded as "opioid" or "opiate" blocks both opioids."""


def allergy_to(inputs: DecisionInputs, drug: str) -> tuple[str, InputUsed] | None:
    """The allergy (substance and reaction, as shown) and the fact read, when one names `drug`."""
    if inputs.intake is None:
        return None
    for allergy in inputs.intake.value.allergies:
        if any(name in allergy.substance.lower() for name in NAMES[drug]):
            reaction = f" ({allergy.reaction})" if allergy.reaction else ""
            return f"{allergy.substance}{reaction}", inputs.intake.used("allergy", allergy.substance)
    return None
