"""The surveys, the mechanism and the order of the recommendations as people read them, in the same words on
the PDF report and the burn center's case page. No drawing here (no fpdf), only text; "—" where a value is not
recorded."""

from __future__ import annotations

from collections.abc import Iterable

from processing.report.figures import clock
from schemas.decision_support import Recommendation
from schemas.record_parts import Mechanism, PrimarySurvey, SecondarySurvey

AIRWAY_SIGNS = (
    "facial_burns",
    "singed_nasal_hair",
    "carbonaceous_sputum",
    "soot_in_mouth_or_nose",
    "hoarse_voice",
    "stridor",
    "oropharyngeal_oedema",
)


def words(value) -> str:
    return str(getattr(value, "value", value)).replace("_", " ")


def yes_no(value: bool | None) -> str:
    return "—" if value is None else "yes" if value else "no"


def amount(value, unit: str = "") -> str:
    return "—" if value is None else f"{value:g}{unit}"


def primary_facts(s: PrimarySurvey) -> list[tuple[str, str]]:
    """ABCDE as label and value rows."""
    a, b, c, d, x = s.airway, s.breathing, s.circulation, s.disability, s.exposure
    signs = [words(n) for n in AIRWAY_SIGNS if getattr(a, n)]
    gcs = [d.gcs_eye, d.gcs_verbal, d.gcs_motor]
    rows = [
        ("Assessed", clock(s.assessed_at)),
        (
            "A — airway",
            f"patent: {yes_no(a.patent)}; intervention: {words(a.intervention)}; "
            f"signs: {', '.join(signs) or 'none recorded'}; "
            f"cervical spine protected: {yes_no(a.cervical_spine_protected)}",
        ),
        (
            "B — breathing",
            f"RR {amount(b.respiratory_rate_per_min, '/min')}; SpO₂ {amount(b.spo2_percent, ' %')}; "
            f"O₂ {amount(b.oxygen_l_per_min, ' L/min')}; COHb {amount(b.carboxyhaemoglobin_percent, ' %')}"
            + (f"; breath sounds: {b.breath_sounds}" if b.breath_sounds else "")
            + ("; circumferential chest burn" if b.circumferential_chest_burn else "")
            + (
                f"; chest movement restricted: {yes_no(b.chest_movement_restricted)}"
                if b.chest_movement_restricted is not None
                else ""
            ),
        ),
        (
            "C — circulation",
            f"HR {amount(c.heart_rate_per_min, '/min')}; BP {amount(c.systolic_bp_mmhg)}/"
            f"{amount(c.diastolic_bp_mmhg)} mmHg; CRT {amount(c.capillary_refill_s, ' s')}; "
            f"IV access: {yes_no(c.iv_access)}; distal pulses: {yes_no(c.distal_pulses_present)}"
            + ("; circumferential limb burn" if c.circumferential_limb_burn else ""),
        ),
        (
            "D — disability",
            (
                f"GCS {sum(gcs)} (E{d.gcs_eye} V{d.gcs_verbal} M{d.gcs_motor})"
                if None not in gcs
                else "GCS not fully recorded"
            )
            + f"; AVPU {words(d.avpu) if d.avpu else '—'}"
            + (f"; pupils {d.pupils}" if d.pupils else "")
            + f"; glucose {amount(d.blood_glucose_mmol_l, ' mmol/L')}",
        ),
        (
            "E — exposure",
            f"temperature {amount(x.temperature_c, ' °C')}; cooled: {yes_no(x.burn_cooled)}"
            f"{f' for {x.cooling_minutes:g} min' if x.cooling_minutes else ''}; "
            f"jewellery removed: {yes_no(x.jewellery_removed)}; kept warm: {yes_no(x.kept_warm)}",
        ),
    ]
    if s.pain_poorly_controlled is not None:
        rows.append(("Pain", "poorly controlled" if s.pain_poorly_controlled else "controlled"))
    return rows


def secondary_lines(s: SecondarySurvey) -> list[str]:
    lines = [f"{words(f.area)}: {f.finding}" for f in s.findings]
    lines += [f"other injury{' (major)' if o.major else ''}: {o.description}" for o in s.other_injuries]
    if s.burn_poses_greatest_risk is not None:
        lines.append(f"the burn poses the greatest risk: {yes_no(s.burn_poses_greatest_risk)}")
    return lines or ["no findings recorded"]


def mechanism_text(m: Mechanism) -> str:
    extra = [
        f"agent: {m.agent}" if m.agent else "",
        "enclosed space" if m.enclosed_space else "",
        f"{m.duration_s:g} s exposure" if m.duration_s is not None else "",
        f"{m.voltage_v:g} V" if m.voltage_v is not None else "",
        "explosion" if m.explosion else "",
        *(
            f"{label}: {yes_no(value)}"
            for label, value in (
                ("account fits the injury", m.account_fits_injury),
                ("child independently mobile", m.child_independently_mobile),
                ("burn pattern of concern", m.pattern_of_concern),
            )
            if value is not None
        ),
    ]
    return f"Mechanism: {words(m.type)}" + "".join(f"; {x}" for x in extra if x)


def urgent_first(recommendations: Iterable[Recommendation]) -> list[Recommendation]:
    """Urgent recommendations before the others, each group in its stored order (records stored before the rules
    sorted them are shown the same way)."""
    return sorted(recommendations, key=lambda r: not r.urgent)
