"""What an analysis says first, in a sentence a clinician reads at the bedside: the area and the perimeter, the
change since the wound's previous measured visit, and how far to trust them (the confidence level and its first
reason). The indicators behind the confidence, the skin tone estimate and the model's held-out figures stay on the
page, one click away."""

from __future__ import annotations

from dataclasses import dataclass

from schemas.analysis import AnalysisResult, AnalysisStatus
from schemas.longitudinal import TrackResult, TrackSession

SCALE_WORDS = {"marker": "the printed marker", "ruler": "the ruler points", "none": "no scale"}


@dataclass(frozen=True)
class ResultSummary:
    measured: str
    """The figures, or why there are none."""
    change: str
    """The change since the previous measured visit of the same wound ("" when there is none)."""
    trust: str
    """How far to trust the figures."""


def _previous(track: TrackResult | None, job_id: str) -> tuple[TrackSession | None, TrackSession | None]:
    """This analysis's visit in the wound's track, and the measured visit before it."""
    if track is None:
        return None, None
    ids = [s.analysis.rstrip("/").rsplit("/", 1)[-1] for s in track.sessions]
    if job_id not in ids:
        return None, None
    here = ids.index(job_id)
    earlier = [s for s in track.sessions[:here] if s.area_cm2 is not None and s.day < track.sessions[here].day]
    return track.sessions[here], earlier[-1] if earlier else None


def _change(result: AnalysisResult, this: TrackSession | None, before: TrackSession | None) -> str:
    area = result.metrics.area_cm2
    if this is None or before is None or area is None or not before.area_cm2:
        return ""
    days = this.day - before.day
    percent = 100 * (area - before.area_cm2) / before.area_cm2
    direction = "smaller" if percent < 0 else "larger"
    size = "about the same as" if abs(percent) < 1 else f"{abs(percent):.0f} % {direction} than"
    return f"{size[0].upper()}{size[1:]} {days:.0f} days earlier ({before.area_cm2:.1f} cm²)."


def _trust(result: AnalysisResult) -> str:
    c = result.confidence
    if c is None:
        return "No confidence was computed for this analysis."
    why = c.reasons[0] if c.reasons else "the photos fit together, the burn was seen from several sides"
    scale = result.scale.method if result.scale else "none"
    source = SCALE_WORDS.get(scale, scale)
    if result.scale and result.scale.uncertainty_percent is not None:
        source += f" (± {result.scale.uncertainty_percent:.1f} %)"
    return f"Confidence {c.level}: {why}. Scale from {source}."


def summary(result: AnalysisResult, track: TrackResult | None, job_id: str) -> ResultSummary:
    m = result.metrics
    if result.status is AnalysisStatus.failed:
        return ResultSummary(f"No measurement: {result.reason or 'the analysis failed'}.", "", "")
    if result.status is AnalysisStatus.unscaled or m.area_cm2 is None:
        measured = "No size in cm: no printed marker or ruler was found in the photos, so only the shape is shown."
        return ResultSummary(measured, "", _trust(result))
    perimeter = f", perimeter {m.perimeter_cm:.1f} cm" if m.perimeter_cm is not None else ""
    measured = f"Burn area {m.area_cm2:.1f} cm² on the 3D surface{perimeter}."
    this, before = _previous(track, job_id)
    return ResultSummary(measured, _change(result, this, before), _trust(result))
