"""The intake as people read it: allergies, current medications, tetanus history and the rest of the history, in
the same words on the PDF report and the burn center's case page. No drawing here (no fpdf), only text.

What the record lacks is said, never filled in: "Allergies not recorded"; medications and tetanus history "not
recorded" beside their label.
A medicine is named as the clinician recorded it; no drug class is added.
"""

from __future__ import annotations

from schemas.record_parts import Allergy, Intake, Medication, TetanusDoses, TetanusStatus

NO_KNOWN_ALLERGIES = "No known allergies"
ALLERGIES_NOT_RECORDED = "Allergies not recorded"
MEDICATIONS_NOT_RECORDED = "not recorded"
TETANUS_NOT_RECORDED = "not recorded"
DOSES = {
    TetanusDoses.three_or_more: "3 or more prior doses of tetanus-toxoid-containing vaccine",
    TetanusDoses.fewer_than_three: "fewer than 3 prior doses of tetanus-toxoid-containing vaccine (none, 1 or 2)",
}
OLDER_SUMMARY = {
    TetanusStatus.up_to_date: "up to date (last dose within 5 years)",
    TetanusStatus.not_up_to_date: "not up to date",
    TetanusStatus.never_immunised: "never immunised",
}


def allergy_text(allergy: Allergy) -> str:
    return f"{allergy.substance} — reaction: {allergy.reaction or 'not recorded'}"


def allergy_lines(intake: Intake | None) -> list[str]:
    """Each allergy with its reaction; or "No known allergies" when the clinician said so and listed none; or
    "Allergies not recorded"."""
    if intake is not None and intake.allergies:
        return [allergy_text(a) for a in intake.allergies]
    if intake is not None and intake.no_known_allergies:
        return [NO_KNOWN_ALLERGIES]
    return [ALLERGIES_NOT_RECORDED]


def medication_text(medication: Medication) -> str:
    return f"{medication.name} — dose: {medication.dose or 'not recorded'}"


def medication_lines(intake: Intake | None) -> list[str]:
    """Each medicine as recorded, with its dose; "not recorded" when the intake lists none (the record has no
    "takes no medicines" answer, so an empty list is not read as one)."""
    if intake is not None and intake.medications:
        return [medication_text(m) for m in intake.medications]
    return [MEDICATIONS_NOT_RECORDED]


def tetanus_recorded(intake: Intake | None) -> bool:
    """Whether the detailed tetanus history (doses, last dose, immunodeficiency) holds anything."""
    if intake is None:
        return False
    return (
        intake.tetanus_doses is not TetanusDoses.unknown
        or intake.last_tetanus_dose is not None
        or intake.years_since_last_tetanus_dose is not None
        or intake.severe_immunodeficiency is not None
    )


def tetanus_lines(intake: Intake | None) -> list[str]:
    """Prior doses, the last dose (its date, or about how many years ago), immunodeficiency; the older summary only
    when it is all the record holds; "not recorded" otherwise."""
    if intake is None:
        return [TETANUS_NOT_RECORDED]
    if not tetanus_recorded(intake):
        if intake.tetanus_status in OLDER_SUMMARY:
            return [f"Tetanus status (older summary form): {OLDER_SUMMARY[intake.tetanus_status]}"]
        return [TETANUS_NOT_RECORDED]
    lines = [DOSES.get(intake.tetanus_doses, "Prior doses: not recorded")]
    if intake.last_tetanus_dose is not None:
        lines.append(f"Last dose on {intake.last_tetanus_dose.isoformat()}")
    elif intake.years_since_last_tetanus_dose is not None:
        lines.append(f"Last dose about {intake.years_since_last_tetanus_dose:g} years ago")
    else:
        lines.append("Last dose: not recorded")
    immune = intake.severe_immunodeficiency
    lines.append(
        "Severe immunodeficiency (HIV infection or other): "
        + ("not recorded" if immune is None else "yes" if immune else "no")
    )
    return lines


def history_facts(intake: Intake | None) -> list[tuple[str, str]]:
    """The rest of the intake as label and value rows, in the order a clinician takes a history."""
    if intake is None:
        return []
    social = intake.social
    flags = [
        "safeguarding concern (suspected non-accidental injury, neglect or abuse)"
        if social.safeguarding_concern
        else "",
        "substance use" if social.substance_use else "",
        "needs rehabilitation support" if social.needs_rehabilitation_support else "",
    ]
    social_text = "; ".join(
        x for x in (f"lives with {social.lives_with}" if social.lives_with else "", *flags, social.notes) if x
    )
    return [
        ("History of present illness", intake.history_of_present_illness),
        ("Past medical history", intake.past_medical_history),
        ("Comorbidities", "; ".join(intake.significant_comorbidities)),
        ("Social", social_text),
    ]
