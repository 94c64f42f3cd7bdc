"""What the healing plots show, taken from the track (track.json) once for the PDF report and the browser pages:
per plot its title, unit, the measured points, the fitted area line and the projected closure.

Only visits measured with a metric scale (status 'ok') are plotted: an unscaled visit's sizes are not in cm or mm.
The fitted line is the track's least-squares slope through the mean of the measured visits, drawn only where two or
more visits were measured.
"""

from __future__ import annotations

import msgspec

from schemas.longitudinal import TrackResult, TrackSession

REFERENCE_MARKS = ((21.0, "day 21"),)
"""Days marked on the area plot: the 21-day healing rule of thumb."""
CLOSURE_MARK = "projected closure"
PRETTY_UNITS = {"cm2": "cm²", "cm3": "cm³"}


class Closure(msgspec.Struct, frozen=True):
    """The day the fitted area line reaches zero, and its 95 % range; `latest` None: the range is open."""

    day: float
    earliest: float | None = None
    latest: float | None = None


class HealingSeries(msgspec.Struct, frozen=True):
    """One healing plot: `kind` names the figure's rounding (figures.DIGITS), `unit` its unit as printed."""

    title: str
    kind: str
    unit: str
    points: list[tuple[float, float]]
    fit: tuple[float, float] | None = None
    """(a, b): area = a + b·day."""
    closure: Closure | None = None
    marks: tuple[tuple[float, str], ...] = ()
    """Reference days (day, label) drawn as dashed lines."""

    def all_marks(self) -> list[tuple[float, str]]:
        """The projected closure and the reference days, as the PDF's line_plot takes them."""
        closure = [(self.closure.day, CLOSURE_MARK)] if self.closure is not None else []
        return closure + list(self.marks)


def _scaled(session: TrackSession) -> bool:
    return session.status == "ok"


def _unit(track: TrackResult, kind: str, default: str) -> str:
    unit = track.units.get(kind, default)
    return PRETTY_UNITS.get(unit, unit)


def _closure(track: TrackResult) -> Closure | None:
    if track.projected_closure_day is None:
        return None
    span = track.projected_closure_range_days or [None, None]
    return Closure(track.projected_closure_day, span[0] if span else None, span[1] if len(span) > 1 else None)


def area_fit(track: TrackResult) -> tuple[float, float] | None:
    """The fitted area line (a, b), area = a + b·day, or None under two measured visits or without a rate."""
    measured = [s for s in track.sessions if _scaled(s) and s.area_cm2 is not None]
    if track.healing_rate_cm2_per_day is None or len(measured) < 2:
        return None
    mean_day = sum(s.day for s in measured) / len(measured)
    mean_area = sum(s.area_cm2 for s in measured) / len(measured)
    slope = -track.healing_rate_cm2_per_day
    return mean_area - slope * mean_day, slope


def healing_series(track: TrackResult) -> tuple[HealingSeries, HealingSeries, HealingSeries]:
    """The area, deepest-relief and volume plots of a track, in that order."""
    scaled = [s for s in track.sessions if _scaled(s)]
    area = HealingSeries(
        title="Burn area",
        kind="area_cm2",
        unit=_unit(track, "area", "cm2"),
        points=[(s.day, s.area_cm2) for s in scaled if s.area_cm2 is not None],
        fit=area_fit(track),
        closure=_closure(track),
        marks=REFERENCE_MARKS,
    )
    relief = HealingSeries(
        title="Deepest relief (geometry)",
        kind="relief_max_mm",
        unit=_unit(track, "relief", "mm"),
        points=[(s.day, s.relief_max_mm) for s in scaled if s.relief_max_mm is not None],
    )
    volume = HealingSeries(
        title="Volume below reference",
        kind="volume_cm3",
        unit=_unit(track, "volume", "cm3"),
        points=[(s.day, s.volume_cm3) for s in scaled if s.volume_cm3 is not None],
    )
    return area, relief, volume
