"""How long an analysis still has to run, from the stage times this gateway has measured: the median of each
stage over its latest finished analyses (stages a try resumed from disk are left out: they took no time then).
The progress heading says the state in words, the step and, once there is a history, the time left:
"Building the surface…, step 4 of 8, about 40 s left"."""

from __future__ import annotations

import datetime as dt
import statistics
from dataclasses import dataclass

from schemas.jobs import AnalysisJob, JobState

STAGES = {  # stage: (share of the work done when it starts, what the job's message says)
    "inputs": (0.00, "checking the pictures"),
    "sfm": (0.02, "placing the pictures in 3D (structure from motion)"),
    "scale": (0.27, "setting the scale from the printed marker"),
    "dense": (0.29, "building the surface (multi-view stereo)"),
    "mesh": (0.62, "meshing the surface"),
    "segment": (0.75, "finding the burn in each picture"),
    "surface": (0.80, "painting the burn onto the surface"),
    "metrics": (0.87, "measuring area, perimeter, relief and volume"),
}

HISTORY = 20
"""Finished analyses whose stage times make the estimate."""

STAGE_WORDS = {
    "inputs": "Checking the pictures",
    "sfm": "Placing the pictures in 3D",
    "scale": "Setting the scale from the marker",
    "dense": "Building the surface",
    "mesh": "Meshing the surface",
    "segment": "Finding the burn in each picture",
    "surface": "Painting the burn onto the surface",
    "metrics": "Measuring the burn",
}
ORDER = list(STAGES)


@dataclass(frozen=True)
class StageTimes:
    median_s: dict[str, float]
    """Stage -> its median seconds on this gateway; empty before the first analysis finished here."""
    analyses: int = 0
    """How many finished analyses they come from."""


def stage_times(timings: list[tuple[dict[str, float], list[str]]]) -> StageTimes:
    """The medians from (timings_s, reused_stages) of finished analyses."""
    seen: dict[str, list[float]] = {}
    for seconds, reused in timings:
        for stage, s in seconds.items():
            if stage in STAGES and stage not in reused:
                seen.setdefault(stage, []).append(s)
    return StageTimes({stage: statistics.median(v) for stage, v in seen.items()}, len(timings))


@dataclass(frozen=True)
class ProgressHeading:
    text: str
    step: int | None = None
    steps: int = len(ORDER)
    remaining_s: float | None = None


def _about(seconds: float) -> str:
    if seconds < 60:
        return f"about {max(5, round(seconds / 5) * 5):.0f} s left"
    return f"about {round(seconds / 60):.0f} min left"


def _remaining(job: AnalysisJob, times: StageTimes, now: dt.datetime) -> float | None:
    if (
        job.stage not in ORDER
        or not job.started_at
        or any(s not in times.median_s for s in ORDER[ORDER.index(job.stage) :])
    ):
        return None
    here = ORDER.index(job.stage)
    after = sum(times.median_s[s] for s in ORDER[here + 1 :])
    from_here = after + times.median_s[job.stage]
    expected = sum(times.median_s.get(s, 0.0) for s in ORDER)
    elapsed = (now - dt.datetime.fromisoformat(job.started_at)).total_seconds()
    return min(from_here, max(after, expected - elapsed))


def heading(job: AnalysisJob, times: StageTimes, now: dt.datetime) -> ProgressHeading:
    if job.state is JobState.queued:
        ahead = f", {job.queue_position - 1} ahead" if job.queue_position and job.queue_position > 1 else ""
        retry = " (to be tried again)" if job.attempts else ""
        return ProgressHeading(f"Waiting for the gateway's worker{ahead}{retry}")
    if job.state is not JobState.running:
        return ProgressHeading(f"Analysis {job.state.value}")
    if job.stage not in ORDER:
        return ProgressHeading("Starting the analysis…")
    step = ORDER.index(job.stage) + 1
    remaining = _remaining(job, times, now)
    left = f", {_about(remaining)}" if remaining is not None else ""
    text = f"{STAGE_WORDS[job.stage]}…, step {step} of {len(ORDER)}{left}"
    shown = None if remaining is None else float(5 * round(remaining / 5))  # an event only when the words change
    return ProgressHeading(text, step, len(ORDER), shown)
