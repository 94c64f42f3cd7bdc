"""The published sources the decision-support rules cite; what was checked in each is in docs/clinical.md."""

from __future__ import annotations

from schemas.decision_support import Source

ACIP_TETANUS = Source(
    guideline=(
        "CDC/ACIP: Prevention of Pertussis, Tetanus, and Diphtheria with Vaccines in the United States "
        "(MMWR Recomm Rep 2018;67(2))"
    ),
    year=2018,
    section="Guide to tetanus prophylaxis in routine wound management (table)",
    url="https://www.cdc.gov/mmwr/volumes/67/rr/rr6702a1.htm",
)
ACIP_TETANUS_2020 = Source(
    guideline="CDC/ACIP: Use of Tetanus Toxoid, Reduced Diphtheria Toxoid, and Acellular Pertussis Vaccines "
    "(MMWR 2020;69(3):77-83), with the 2018 wound-management table",
    year=2020,
    section="Td or Tdap for tetanus prophylaxis in wound management",
    url="https://www.cdc.gov/mmwr/volumes/69/wr/mm6903a5.htm",
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
