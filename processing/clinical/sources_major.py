"""Sources of the rules for a major burn (airway, oxygen, circulation, warmth, opioids, mechanism, safeguarding).

What was checked in each, and what was left out, is in docs/clinical.md.
"""

from __future__ import annotations

from schemas.decision_support import Source

VICBURNS_AIRWAY = Source(
    guideline="Victorian Adult Burns Service: Early management of severe burns: Airway and breathing support",
    section="Consider intubation in patients whose airway is at risk; 100 % high-flow (15 L/min) humidified oxygen",
    url="https://www.vicburns.org.au/severe-burns/early-management-of-severe-burns/airway-and-breathing-support",
    accessed="2026-12-06",
)
RCEM_AIRWAY = Source(
    guideline="Royal College of Emergency Medicine (RCEM Learning): Major trauma: burns, Airway",
    section="Features of inhalation injury; any suspected airway injury needs senior anaesthetic review",
    url="https://www.rcemlearning.org/modules/major-trauma-burns/lessons/airway/",
    accessed="2026-12-06",
)
JTS_BURN_CARE = Source(
    guideline="Joint Trauma System (US Department of Defense) Clinical Practice Guideline: Burn Care",
    year=2016,
    section="Airway (intubation indications); Escharotomy (hourly vascular exam, elevation); Hypothermia",
    url="https://books.allogy.com/v1/tenant/8/books/d6f7fa3a-b0fd-45f7-81d7-15f1f64e2f51",
    accessed="2026-12-06",
)
VICBURNS_CIRCUMFERENTIAL = Source(
    guideline="Victorian Adult Burns Service: Secondary survey: Circumferential burn",
    section="Distal neurovascular observations; signs of compromise; consult before escharotomy",
    url="https://www.vicburns.org.au/severe-burns/secondary-survey/circumferential-burn",
    accessed="2026-12-06",
)
VICBURNS_HEAT_LOSS = Source(
    guideline="Victorian Adult Burns Service: Early management of severe burns: Prevent heat loss",
    section="Who is at risk; cover, warm fluids, warm room; stop cooling if core temperature < 35 °C",
    url="http://www.vicburns.org.au/severe-burns/early-management/prevent-heat-loss/",
    accessed="2026-12-06",
)
VICBURNS_ANALGESIA = Source(
    guideline="Victorian Adult Burns Service: Early management of severe burns: Analgesia",
    section="IV route; morphine 2-5 mg IV every 5 minutes, titrated to response (adults)",
    url="https://vicburns.org.au/severe-burns/early-management-of-severe-burns/analgesia",
    accessed="2026-12-06",
)
PCH_BURNS_ANALGESIA = Source(
    guideline="Perth Children's Hospital (WA Health) Emergency Department guideline: Burns: analgesia and dosing",
    section="Severe pain: IV fentanyl 0.5-2 microgram/kg (initial maximum 50 microgram), or morphine",
    url="https://pch.health.wa.gov.au/For-health-professionals/Emergency-Department-Guidelines/Burns-Analgesia-and-dosing",
    accessed="2026-12-06",
)
JTS_PFC_BURN = Source(
    guideline="Joint Trauma System Clinical Practice Guideline: Burn wound management in prolonged field care (ID 57)",
    year=2017,
    section="Hypothermia: anticipate it in every burn; rewarm actively below 36 °C",
    url="https://tccc.org.ua/en/guide/burn-wound-management-under-prolonged-field-care-pcc",
    accessed="2026-12-06",
)
VICBURNS_BREATHING = Source(
    guideline="Victorian Adult Burns Service: Primary survey: Breathing and ventilation",
    section="Smoke inhalation: carbon monoxide; 100 % high-flow (15 L/min) humidified oxygen by mask or tube",
    url="https://www.vicburns.org.au/severe-burns/primary-survey/breathing-ventilation/",
    accessed="2026-12-06",
)
EBMG_CARBON_MONOXIDE = Source(
    guideline="Duodecim: Evidence-Based Medicine Guidelines (EBMG): Carbon monoxide poisoning",
    section="COHb over 10 % always signifies poisoning; 100 % oxygen until symptoms subside and COHb is under 5 %; "
    "pulse oximetry cannot tell COHb from oxyhaemoglobin",
    url="http://ebook.sicseditore.it/ebm/ebm00933-Carbon-monoxide-poisoning.asp",
    accessed="2026-12-06",
)
NICE_CHILD_MALTREATMENT = Source(
    guideline="NICE clinical guideline CG89: Child maltreatment: when to suspect maltreatment in under 18s",
    year=2009,
    section="1.1 Physical features: burns and scalds; definitions of 'consider' and 'suspect'",
    url="https://www.nice.org.uk/guidance/cg89",
    accessed="2026-12-06",
)
EM_PRACTICE_ELECTRICAL = Source(
    guideline="Czuczman AD, Zane RD. Electrical injuries: a review for the emergency clinician. Emergency Medicine "
    "Practice 2009;11(10), evidence-based practice recommendations (after the American Burn Association practice "
    "guidelines, Arnoldo et al., J Burn Care Res 2006)",
    year=2009,
    section="An initial ECG for all; cardiac monitoring for arrhythmia or ischaemia on the ECG, loss of "
    "consciousness, or a high-voltage (> 1000 V) injury",
    url="https://scribd.com/document/212286410/1009-Elect-Injuries-Practice-Recs",
    accessed="2026-12-06",
)
VICBURNS_CHEMICAL = Source(
    guideline="Victorian Adult Burns Service: First aid: Chemical burns",
    section="Protective equipment; remove clothing; prolonged water irrigation while pain persists or until the skin "
    "pH is normal",
    url="https://www.vicburns.org.au/first-aid/chemical/",
    accessed="2026-12-06",
)
VICBURNS_SEVERE_CHEMICAL = Source(
    guideline="Victorian Adult Burns Service: Secondary survey: Severe chemical burns",
    section="Hydrofluoric acid: very small amounts can be fatal, arrhythmias; calcium gluconate gel or local 10 % "
    "calcium gluconate",
    url="https://www.vicburns.org.au/severe-burns/secondary-survey/severe-chemical-burns",
    accessed="2026-12-06",
)
