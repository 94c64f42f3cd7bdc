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
ANZCOR_FIRST_AID = Source(
    guideline="ANZCOR Guideline 9.1.3: First Aid for Burns (Australian and New Zealand Committee on Resuscitation)",
    section="Cooling: at least 20 minutes; may help if started up to 3 hours after the burn",
    url="https://www.anzcor.org/home/first-aid-management-of-injuries/guideline-9-1-3-first-aid-for-burns/",
    accessed="2026-12-02",
)
VICBURNS_DEPTH = Source(
    guideline="Victorian Adult Burns Service: Estimate burn depth; When to refer and FAQs",
    section="Reassessment ideally within 48 hours; refer if depth unclear after 3-5 days",
    url="https://www.vicburns.org.au/burn-assessment/burn-depth",
    accessed="2026-12-02",
)
VICBURNS_ANTIBIOTICS = Source(
    guideline="Victorian Adult Burns Service: When to refer and FAQs; Australian Prescriber 2015;38:124-7 "
    "(Minor burn management: potions and lotions)",
    year=2015,
    section="Prophylactic antibiotics after burn injury: no; only for signs of infection",
    url="https://www.vicburns.org.au/minor-burns/when-to-refer-and-FAQs/",
)
TSS_CHILDREN = Source(
    guideline="Young AE, Thornton KL. Toxic shock syndrome in burns: diagnosis and management. Arch Dis Child "
    "Educ Pract Ed 2007;92(4):ep97-100; British Burn Association criteria as summarised by RCEM Learning",
    year=2007,
    section="Children with small burns: pyrexia > 38.9 °C, rash or sudden change within a few days",
    url="https://ep.bmj.com/content/92/4/ep97",
)
BBA_NOT_HEALED = Source(
    guideline="British Burn Association minimum threshold for referral (as reproduced by RCEM Learning and North "
    "Bristol NHS Trust)",
    section="Any burn not healed in 2 weeks",
    url="https://www.rcemlearning.org/modules/major-trauma-burns/lessons/special-circumstances/",
    accessed="2026-12-02",
)
RCH_ANALGESIA = Source(
    guideline="Royal Children's Hospital Melbourne Clinical Practice Guidelines: Analgesia and sedation; "
    "Intranasal fentanyl",
    section="Paracetamol 15 mg/kg (max 1 g) 4-6 hourly, max 60 mg/kg/day; intranasal fentanyl 1.5 mcg/kg",
    url="https://www.rch.org.au/clinicalguide/guideline_index/Analgesia_and_sedation/",
    accessed="2026-12-02",
)
NHS_PARACETAMOL_ADULT = Source(
    guideline="NHS medicines: Paracetamol for adults, how and when to take it",
    section="500 mg or 1 g, at least 4 hours apart, at most 4 g (8 x 500 mg) in 24 hours",
    url="https://www.nhs.uk/medicines/paracetamol-for-adults/how-and-when-to-take-paracetamol-for-adults/",
    accessed="2026-12-02",
)
VICBURNS_DRESSINGS = Source(
    guideline="Victorian Adult Burns Service: Minor burn wound management (ANZBA Initial Management of Minor Burns)",
    section="Dressing by depth: epidermal and superficial dermal rows",
    url="https://vicburns.org.au/minor-burns/minor-burn-wound-managment",
    accessed="2026-12-02",
)
ELEVATION = Source(
    guideline="Cleland H. Thermal burns: assessment and acute management in the general practice setting. Aust Fam "
    "Physician 2012;41(6):372-5; Victorian burns first-aid page for children",
    year=2012,
    section="Dressings, rest, elevation and oedema control",
    url="http://www.racgp.org.au/afp/2012/june/thermal-burns-assessment-and-acute-management/",
)
