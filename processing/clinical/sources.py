"""The published sources the decision-support rules cite; what was checked in each is in docs/clinical.md."""

from __future__ import annotations

from schemas.decision_support import Source

ACIP_TETANUS = Source(
    guideline="CDC/ACIP: Guide to tetanus prophylaxis in routine wound management (as reproduced in the MSD Manual "
    "Professional, 2023, and CDC's Summary Guide to Tetanus Prophylaxis in Routine Wound Management)",
    year=2023,
    section="Table: prior doses (unknown or < 3; >= 3) x wound (clean and minor; all other wounds, burns included)",
    url="https://www.msdmanuals.com/professional/multimedia/table/tetanus-prophylaxis-in-routine-wound-management",
)
ABLS_FLUIDS = Source(
    guideline="American Burn Association: Advanced Burn Life Support (ABLS) Provider Manual",
    year=2018,
    section="Chapter 4, Shock and fluid resuscitation (fluid formulas, urine-output targets)",
)
ABA_REFERRAL = Source(
    guideline="American Burn Association: Guidelines for Burn Patient Referral",
    year=2022,
    section="Immediate consultation / consultation recommended table",
    url="https://www.ameriburn.org/burn-care-team/resources/guidelines-for-burn-patient-referral",
)
KANTOR_MARGOLIS = Source(
    guideline="Kantor J, Margolis DJ. Br J Dermatol 2000;142(5):960-964 (venous leg ulcers, not burns)",
    year=2000,
    section="Percentage change in area over the first 4 weeks",
)
DEITCH = Source(
    guideline="Deitch EA, et al. Hypertrophic burn scars: analysis of variables. J Trauma 1983;23(10):895-898",
    year=1983,
    section="Healing time and hypertrophic scarring",
)
