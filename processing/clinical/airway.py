"""The airway at risk: signs of inhalation injury call for early airway assessment by the most experienced person.

The signs are those the primary survey records (schemas/record_parts.py Airway), a raised carboxyhaemoglobin and an
enclosed-space fire (RCEM). The
intubation indications are the sources': stridor is an immediate indication (Victorian Adult Burns Service); a
GCS under 9, increasing head and neck swelling and a transfer with doubt about the airway are others; the Joint
Trauma System adds deep facial burns and burns of 40 %TBSA or more. Oxygen for carbon monoxide is in
processing/clinical/oxygen.py.
"""

from __future__ import annotations

from processing.clinical.decision_inputs import DecisionInputs
from processing.clinical.sources_major import JTS_BURN_CARE, RCEM_AIRWAY, VICBURNS_AIRWAY
from schemas.burn_chart import BurnDepth
from schemas.decision_support import InputUsed, Recommendation, RecommendationCategory
from schemas.record_parts import AirwayIntervention

SIGNS = {
    "facial_burns": "facial burns",
    "singed_nasal_hair": "singed nasal hair",
    "carbonaceous_sputum": "carbonaceous sputum",
    "soot_in_mouth_or_nose": "soot in the mouth or nose",
    "hoarse_voice": "hoarse voice",
    "stridor": "stridor",
    "oropharyngeal_oedema": "swelling of the mouth and throat",
}
COHB_RAISED_OVER = 10.0
"""A carboxyhaemoglobin over 10 % always signifies poisoning (EBMG); RCEM lists a raised CO among the signs."""
INTUBATION_TBSA = 40.0
"""Joint Trauma System: burns over 40 %TBSA are an indication for intubation."""
GCS_BELOW = 9
"""Victorian Adult Burns Service: GCS < 9."""
SECURED = (AirwayIntervention.intubated, AirwayIntervention.surgical_airway)
FACE_REGIONS = ("head_anterior",)
"""The front of the head on the Lund-Browder chart: the face."""
DEEP = (BurnDepth.deep_partial, BurnDepth.full_thickness)
INDICATIONS = (
    "Intubation indications (Victorian Adult Burns Service): stridor (immediate); increasing head and neck swelling; "
    "altered consciousness or unable to protect the airway; GCS under 9; uncooperative or combative; consider it "
    "before a long or delayed transfer when there is doubt about the airway. Use an uncut tube; capnography.",
    "The Joint Trauma System CPG adds symptomatic inhalation injury, deep facial burns and burns over 40 %TBSA.",
    "Sit the patient up. Airway swelling can develop over hours: reassess often.",
)


def signs_present(inputs: DecisionInputs) -> list[InputUsed]:
    """The signs of inhalation injury recorded, as facts (the ABCDE's airway signs and an enclosed-space fire)."""
    found: list[InputUsed] = []
    if inputs.primary is not None:
        airway = inputs.primary.value.airway
        found += [inputs.primary.used(label, True) for name, label in SIGNS.items() if getattr(airway, name)]
        level = inputs.primary.value.breathing.carboxyhaemoglobin_percent
        if level is not None and level > COHB_RAISED_OVER:
            found.append(inputs.primary.used("raised carboxyhaemoglobin", f"{level:g} %"))
    if inputs.mechanism is not None and inputs.mechanism.value.enclosed_space:
        found.append(inputs.mechanism.used("fire in an enclosed space", True))
    return found


def recommend(inputs: DecisionInputs) -> tuple[list[Recommendation], list[str]]:
    signs = signs_present(inputs)
    if inputs.primary is None:
        return [], ["primary survey (ABCDE): the airway signs of inhalation injury are not judged"]
    if not signs:
        return [], []
    airway = inputs.primary.value.airway
    if airway.intervention in SECURED:
        return [], []
    shown = ", ".join(s.name for s in signs)
    lead = "Stridor is an immediate indication for intubation. " if airway.stridor else ""
    text = (
        f"Airway at risk: suspected inhalation injury ({shown}). {lead}Early assessment of the airway by the most "
        "experienced person available (a senior anaesthetist), to decide on early intubation before swelling makes "
        "it difficult."
    )
    used = list(signs)
    found = _indications_met(inputs, used)
    details = [*found, *INDICATIONS]
    return [
        Recommendation(
            key="airway.inhalation",
            category=RecommendationCategory.airway,
            text=text,
            details=details,
            inputs=used,
            source=RCEM_AIRWAY if not airway.stridor else VICBURNS_AIRWAY,
            urgent=True,
        )
    ], []


def _indications_met(inputs: DecisionInputs, used: list[InputUsed]) -> list[str]:
    """The intubation indications this record meets, each stated with its figure."""
    out = []
    disability = inputs.primary.value.disability
    parts = (disability.gcs_eye, disability.gcs_verbal, disability.gcs_motor)
    if all(p is not None for p in parts) and sum(parts) < GCS_BELOW:
        used.append(inputs.primary.used("GCS", sum(parts)))
        out.append(f"Recorded GCS {sum(parts)}: under {GCS_BELOW}, an indication for intubation.")
    tbsa = inputs.assessment.value.tbsa if inputs.assessment is not None else None
    if tbsa is not None and tbsa.tbsa_percent > INTUBATION_TBSA:
        used.append(inputs.assessment.used("%TBSA", f"{tbsa.tbsa_percent:g} %"))
        out.append(
            f"Burn of {tbsa.tbsa_percent:g} %TBSA: over {INTUBATION_TBSA:g} %, an intubation indication in the "
            f"{JTS_BURN_CARE.guideline.split(':')[0]} CPG."
        )
    chart = inputs.chart
    if chart is not None and any(e.region.value in FACE_REGIONS and e.depth in DEEP for e in chart.value.entries):
        used.append(chart.used("deep burn of the face charted", True))
        out.append(
            "Deep burn of the front of the head (the face) charted: an intubation indication in the Joint Trauma System CPG."
        )
    return out
