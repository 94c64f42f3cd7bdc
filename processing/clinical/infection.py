"""Infection monitoring: no routine prophylactic antibiotics, and toxic shock syndrome in children.

When to take a wound swab is not said: no checked source stated it (docs/clinical.md).
"""

from __future__ import annotations

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.sources import TSS_CHILDREN, VICBURNS_ANTIBIOTICS
from schemas.decision_support import Recommendation, RecommendationCategory

CHILD_UNDER_YEARS = 16.0
"""Toxic shock syndrome advice applies to children; the sources do not set an age, so under 16 is used."""


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    if inputs.chart is None:
        return [], []
    out = [
        Recommendation(
            key="infection.antibiotics",
            category=RecommendationCategory.infection,
            text="Infection: routine prophylactic systemic antibiotics are not recommended after a burn; give "
            "antibiotics only for signs of infection, guided by sensitivities.",
            inputs=[inputs.chart.used("burn charted", True)],
            source=VICBURNS_ANTIBIOTICS,
        )
    ]
    age = inputs.age_used()
    if inputs.age_years is not None and inputs.age_years < CHILD_UNDER_YEARS:
        out.append(
            Recommendation(
                key="infection.toxic_shock",
                category=RecommendationCategory.infection,
                text="Child with a burn: watch for toxic shock syndrome in the first days, whatever the burn's size. "
                "A temperature above 38.9 °C, a rash, or a sudden change in condition: monitor closely, and refer "
                "early if it is suspected.",
                details=[
                    "Signs (British Burn Association): pyrexia, rash, diarrhoea or vomiting, general malaise, "
                    "anorexia, tachycardia, tachypnoea or hypotension, reduced urine output.",
                    "Some parent leaflets use 38 °C as the temperature to act on.",
                ],
                inputs=[age],
                source=TSS_CHILDREN,
            )
        )
    return out, []
