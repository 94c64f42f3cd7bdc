"""How the report prints each figure: one rounding per kind, so a reader (and a test) can check it against the
stored record."""

from __future__ import annotations

import datetime as dt

DIGITS = {
    "area_cm2": 2,
    "perimeter_cm": 1,
    "relief_max_mm": 1,
    "relief_mean_mm": 1,
    "raised_max_mm": 1,
    "volume_cm3": 2,
    "tbsa_percent": 3,
    "scale_uncertainty_percent": 1,
    "confidence": 2,
    "lund_browder_percent": 2,
    "rate_ml_per_h": 0,
    "volume_ml": 0,
    "healing_rate_cm2_per_day": 3,
    "closure_day": 0,
}
UNITS = {
    "area_cm2": "cm²",
    "perimeter_cm": "cm",
    "relief_max_mm": "mm",
    "relief_mean_mm": "mm",
    "raised_max_mm": "mm",
    "volume_cm3": "cm³",
    "tbsa_percent": "% TBSA",
}


def figure(value: float | None, kind: str, unit: str | None = None) -> str:
    """A figure with its unit at the report's rounding; "—" when there is none."""
    if value is None:
        return "—"
    digits = DIGITS[kind]
    unit = UNITS.get(kind, "") if unit is None else unit
    text = f"{value:,.{digits}f}"
    return f"{text} {unit}".strip()


def clock(t: dt.datetime | None) -> str:
    if t is None:
        return "not recorded"
    return t.astimezone(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")


def hours(h: float | None) -> str:
    if h is None:
        return "unknown"
    if h < 48:
        return f"{h:.1f} h"
    return f"{h / 24:.1f} days"
