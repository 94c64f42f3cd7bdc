"""The report's first page: who and when, what the record lacks, the figures a reader looks for first, and the
history a clinician must see before treating (allergies, current medications, tetanus), then the rest of the
intake."""

from __future__ import annotations

from processing.clinical.referral_rules import NOT_ASSESSABLE
from processing.report.figures import clock, figure
from processing.report.history_text import allergy_lines, history_facts, medication_lines, tetanus_lines
from processing.report.layout import GREY, NOT_RECORDED, URGENT, ReportPDF
from processing.report.record_text import words
from schemas.clinical_results import FluidPhase
from schemas.encounter_snapshot import EncounterSnapshot


def header(pdf: ReportPDF, r: EncounterSnapshot, missing: list[str]) -> None:
    p, e = r.patient.value, r.encounter.value
    pdf.doc_title("Burn assessment report")
    pdf.para("Decision support only — every figure and recommendation is confirmed by a clinician.", bold=True)
    name = " ".join(x for x in (p.given_name, p.family_name) if x)
    name = name or (f"{p.temporary_label} (unknown patient)" if p.temporary_label else NOT_RECORDED)
    age = r.assessment.value.age_years if r.assessment else None
    born = (
        p.date_of_birth.isoformat()
        if p.date_of_birth
        else f"estimated age {p.age_estimate_years:g} y"
        if (p.age_estimate_years is not None)
        else NOT_RECORDED
    )
    weight = e.weight_kg or p.weight_kg
    source = "this encounter" if e.weight_kg else (words(p.weight_source) if p.weight_source else "source not recorded")
    rows = [
        ("Clinic", r.clinic or e.facility or NOT_RECORDED),
        ("Patient", f"{name} · MRN {p.medical_record_number or NOT_RECORDED} · id {p.id}"),
        ("Born / age", f"{born}" + (f" · {age:g} y at injury" if age is not None else "")),
        ("Sex", words(p.sex)),
        (
            "Weight / height",
            f"{f'{weight:g} kg ({source})' if weight else NOT_RECORDED} · "
            f"{f'{p.height_cm:g} cm' if p.height_cm else 'height ' + NOT_RECORDED}",
        ),
        ("Encounter", f"{words(e.mode)} · id {e.id}"),
        ("Injury", clock(e.time_of_injury)),
        ("Arrival", clock(e.time_of_arrival)),
        ("Responsible clinician", e.clinician or NOT_RECORDED),
        ("Report made", f"{clock(r.made_at)} by {r.made_by} · burnedge {r.software_version}"),
    ]
    if r.audit_head is not None:
        rows.append(("Audit chain", f"entry {r.audit_head.seq}, hash {r.audit_head.hash[:16]}… before this report"))
    pdf.facts(rows)
    if missing:
        pdf.subheading("Not in the record (figures that need it are not shown)")
        pdf.bullets(missing, colour=GREY)


def at_a_glance(pdf: ReportPDF, r: EncounterSnapshot) -> None:
    """The figures a reader looks for first, each with where it is detailed."""
    pdf.heading("At a glance")
    a = r.assessment.value if r.assessment else None
    rows = []
    if a is not None and a.tbsa is not None:
        rows.append(
            ("%TBSA", f"{figure(a.tbsa.tbsa_percent, 'lund_browder_percent', '%')} (Lund-Browder; see Burn chart)")
        )
    else:
        rows.append(("%TBSA", "not computed (burn chart or age missing)"))
    if a is not None and a.referral is not None:
        rows.append(("Referral", a.referral.current.recommendation.split(NOT_ASSESSABLE)[0]))
    plan = r.fluids_now
    if plan is not None and plan.formal_resuscitation_indicated and plan.phase is not FluidPhase.complete:
        rows.append(
            (
                "Fluids now",
                f"{figure(plan.rate_now_ml_per_h, 'rate_ml_per_h', 'mL/h')} "
                f"(as of {clock(plan.as_of)}; titrate to urine output)",
            )
        )
    elif plan is not None:
        rows.append(("Fluids", "formal resuscitation not indicated or its 24 hours are over (see Fluids)"))
    for wound in r.healing:
        measured = [s for s in (wound.track.sessions if wound.track else []) if s.area_cm2 is not None]
        if not measured:
            continue
        last = measured[-1]
        name = f"Latest area, {wound.label}" if len(r.healing) > 1 else "Latest burn area"
        share = wound.share
        percent = f", {share.measured_percent:.3f} %TBSA" if share and share.measured_percent is not None else ""
        flagged = "; CHECK the chart against it (see Healing over time)" if share and share.flag else ""
        rows.append(
            (
                name,
                f"{figure(last.area_cm2, 'area_cm2')}{percent} on day {last.day:.0f} "
                f"({len(measured)} measured visit{'s' if len(measured) > 1 else ''}; see Healing over time){flagged}",
            )
        )
    support = r.decision_support.value if r.decision_support else None
    if support is not None:
        pending = [x for x in support.recommendations if x.state.value == "pending"]
        urgent = [x for x in pending if x.urgent]
        rows.append(
            (
                "Recommendations",
                f"{len(support.recommendations)}, {len(pending)} pending a clinician's "
                f"decision, {len(urgent)} of them urgent (see Decision support)",
            )
        )
    pdf.facts(rows)
    if support is not None:
        for rec in support.recommendations:
            if rec.urgent and rec.state.value == "pending":
                pdf.para(f"URGENT, pending: {rec.text}", colour=URGENT, size=8.5)


def history(pdf: ReportPDF, r: EncounterSnapshot) -> None:
    pdf.heading("History: allergies, medications, tetanus", new_page_if_below=45)
    intake = r.intake.value if r.intake else None
    if intake is None:
        pdf.para("No intake recorded: the history below is not known.", colour=GREY)
    pdf.facts(
        [
            ("Allergies", "\n".join(allergy_lines(intake))),
            ("Current medications", "\n".join(medication_lines(intake))),
            ("Tetanus history", "\n".join(tetanus_lines(intake))),
            *history_facts(intake),
        ]
    )
