"""The record's sections: who and when, the surveys, the mechanism, the burn chart, fluids and referral."""

from __future__ import annotations

from processing.report.body_diagram import draw_body_chart
from processing.report.figures import clock, figure
from processing.report.layout import GREY, URGENT, ReportPDF
from processing.report.record_text import mechanism_text, primary_facts, secondary_lines, words
from schemas.burn_chart import BurnDepth, region_name
from schemas.clinical_results import FluidPhase
from schemas.encounter_snapshot import EncounterSnapshot

DEPTH_ORDER = list(BurnDepth)
DEPTH_LABEL = {
    BurnDepth.superficial: "superficial (epidermal)",
    BurnDepth.superficial_partial: "superficial partial thickness",
    BurnDepth.deep_partial: "deep partial thickness",
    BurnDepth.full_thickness: "full thickness",
}


def surveys(pdf: ReportPDF, r: EncounterSnapshot) -> None:
    pdf.heading("Primary survey (ABCDE)")
    if r.primary is None:
        pdf.para("No primary survey recorded.", colour=GREY)
    else:
        pdf.facts(primary_facts(r.primary.value))
    pdf.heading("Secondary survey and mechanism")
    if r.secondary is None:
        pdf.para("No secondary survey recorded.", colour=GREY)
    else:
        pdf.bullets(secondary_lines(r.secondary.value))
        if r.secondary.value.notes:
            pdf.para(r.secondary.value.notes)
    if r.mechanism is None:
        pdf.para("Mechanism not recorded.", colour=GREY)
    else:
        pdf.para(mechanism_text(r.mechanism.value))
        if r.mechanism.value.description:
            pdf.para(r.mechanism.value.description)


def burn_chart(pdf: ReportPDF, r: EncounterSnapshot) -> None:
    pdf.heading("Burn chart and %TBSA", new_page_if_below=110)
    if r.chart is None:
        pdf.para(
            "No burn chart recorded: %TBSA, the fluid plan and the referral criteria cannot be computed.", colour=GREY
        )
        return
    chart = r.chart.value
    deepest: dict = {}
    for entry in chart.entries:
        known = deepest.get(entry.region)
        if known is None or DEPTH_ORDER.index(entry.depth) > DEPTH_ORDER.index(known):
            deepest[entry.region] = entry.depth
    y = pdf.get_y()
    draw_body_chart(pdf, pdf.l_margin, y, pdf.epw * 0.62, 92, deepest)
    pdf.set_y(y + 94)
    pdf.para(
        f"Charted by the clinician at {clock(chart.assessed_at)}; depth is the clinician's category, not a "
        "measurement. Where a region has several depths the drawing shows the deepest.",
        colour=GREY,
    )
    tbsa = r.assessment.value.tbsa if r.assessment else None
    if tbsa is not None:
        pdf.facts(
            [
                (
                    "%TBSA (Lund-Browder)",
                    f"{figure(tbsa.tbsa_percent, 'lund_browder_percent', '%')} "
                    f"(partial thickness {tbsa.partial_thickness_percent:.2f} %, full thickness "
                    f"{tbsa.full_thickness_percent:.2f} %; superficial {tbsa.excluded_superficial_percent:.2f} % excluded)",
                ),
                ("Rule of Nines", f"{tbsa.rule_of_nines_percent:.2f} % ({tbsa.rule_of_nines_variant}), for comparison"),
                ("Age column", f"{tbsa.age_adjustment} (age {tbsa.age_years:g} y, {words(tbsa.age_source)})"),
            ]
        )
        rows = [
            [region_name(c.region), DEPTH_LABEL[c.depth], f"{c.fraction:.0%}", f"{c.tbsa_percent:.2f} %"]
            for c in tbsa.contributions
        ]
        pdf.table(["Region", "Depth", "Share burned", "%TBSA"], rows, [62, 58, 28, 30])
    for area in chart.special_areas:
        pdf.para(f"Special area: {words(area.area)} ({DEPTH_LABEL[area.depth]})")


def fluids(pdf: ReportPDF, r: EncounterSnapshot) -> None:
    pdf.heading("Fluids", new_page_if_below=50)
    plan = r.fluids_now
    if plan is None:
        pdf.para("No fluid plan: it needs the weight, the burn chart, the age and the time of injury.", colour=GREY)
        return
    if not plan.formal_resuscitation_indicated:
        pdf.para(
            f"Burn of {plan.tbsa_percent:g} %TBSA, under the {plan.formal_resuscitation_threshold_percent:g} % "
            "threshold: formal resuscitation is not usually required. Formula figures below are for reference.",
            bold=True,
            colour=URGENT,
        )
    urine = plan.urine_output_target
    running = plan.phase is not FluidPhase.complete
    rows = [
        ("As of", f"{clock(plan.as_of)} ({plan.hours_since_injury:.1f} h since injury)"),
        (
            "Formula",
            f"{plan.multiplier_basis} × {plan.weight_kg:g} kg ({plan.weight_source}) × {plan.tbsa_percent:g} %",
        ),
        (
            "24-hour volume",
            f"{figure(plan.total_24h_ml, 'volume_ml', 'mL')}: {figure(plan.first_8h_ml, 'volume_ml', 'mL')}"
            f" in the first 8 h, {figure(plan.next_16h_ml, 'volume_ml', 'mL')} in the next 16 h",
        ),
        ("Given so far", figure(plan.fluid_given_ml, "volume_ml", "mL")),
        (
            "Rate now",
            f"{figure(plan.rate_now_ml_per_h, 'rate_ml_per_h', 'mL/h')}" if running else "formula period over",
        ),
        (
            "Still due in phase",
            f"{figure(plan.remaining_in_phase_ml, 'volume_ml', 'mL')} over {plan.hours_left_in_phase:.1f} h"
            f" ({words(plan.phase)})"
            if running
            else "—",
        ),
        (
            "Urine output target",
            f"{urine.ml_per_kg_per_h_low:g}–{urine.ml_per_kg_per_h_high:g} mL/kg/h = "
            f"{urine.ml_per_h_low:,.0f}–{urine.ml_per_h_high:,.0f} mL/h ({urine.basis})",
        ),
    ]
    if plan.maintenance is not None:
        rows.append(("Maintenance (child)", f"{plan.maintenance.ml_per_h:,.1f} mL/h ({plan.maintenance.rule})"))
    pdf.facts(rows)
    pdf.bullets(plan.warnings, colour=GREY)


def referral(pdf: ReportPDF, r: EncounterSnapshot) -> None:
    pdf.heading("Referral to a burn center", new_page_if_below=40)
    result = r.assessment.value.referral if r.assessment else None
    if result is None:
        pdf.para("Referral criteria not assessed (the burn chart and the age are needed).", colour=GREY)
        return
    current = result.current
    pdf.para(f"{current.guideline}, version {current.version}: {current.recommendation}", bold=True)
    pdf.bullets([f"{c.text} — {c.reason}" for c in current.criteria if c.met])
    pdf.para(
        f"For comparison, {result.older.guideline} {result.older.version}: {result.older.recommendation}", colour=GREY
    )
