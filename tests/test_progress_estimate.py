"""The analysis's progress heading: its state in words, the step, and the time left from the stage times this
gateway measured (gateway/jobs/estimate.py)."""

from __future__ import annotations

import datetime as dt

from gateway.jobs.estimate import ORDER, heading, stage_times
from schemas.jobs import AnalysisJob, JobState

NOW = dt.datetime(2026, 12, 6, 12, 0, tzinfo=dt.UTC)
TEN_EACH = {stage: 10.0 for stage in ORDER}  # 80 s in all


def _job(state=JobState.running, stage="", started_s_ago: float | None = None, **extra) -> AnalysisJob:
    started = (NOW - dt.timedelta(seconds=started_s_ago)).isoformat() if started_s_ago is not None else None
    return AnalysisJob(
        id="j", encounter_id="e", patient_id="p", state=state, priority=0, stage=stage, started_at=started, **extra
    )


def test_the_medians_leave_out_stages_a_try_resumed():
    times = stage_times(
        [
            ({"sfm": 30.0, "dense": 100.0}, []),
            ({"sfm": 50.0, "dense": 0.1}, ["dense"]),
            ({"sfm": 40.0, "dense": 120.0, "unknown": 5.0}, []),
        ]
    )
    assert times.median_s == {"sfm": 40.0, "dense": 110.0} and times.analyses == 3


def test_a_running_analysis_says_its_step_and_the_time_left():
    said = heading(_job(stage="dense", started_s_ago=30), stage_times([(TEN_EACH, [])]), NOW)
    assert said.text == "Building the surface…, step 4 of 8, about 50 s left"  # 80 s expected, 30 s gone
    assert (said.step, said.steps, said.remaining_s) == (4, 8, 50.0)


def test_the_time_left_never_drops_below_the_stages_still_to_come():
    said = heading(_job(stage="mesh", started_s_ago=500), stage_times([(TEN_EACH, [])]), NOW)
    assert said.remaining_s == 30.0  # a slow run: still the three stages after meshing
    long = heading(_job(stage="sfm", started_s_ago=0), stage_times([({s: 90.0 for s in ORDER}, [])]), NOW)
    assert long.text.endswith("about 10 min left")


def test_without_a_history_there_is_no_estimate_and_no_made_up_time():
    said = heading(_job(stage="segment", started_s_ago=10), stage_times([]), NOW)
    assert said.text == "Finding the burn in each picture…, step 6 of 8" and said.remaining_s is None


def test_a_queued_analysis_says_how_many_are_ahead():
    assert heading(_job(JobState.queued, queue_position=3), stage_times([]), NOW).text == (
        "Waiting for the gateway's worker, 2 ahead"
    )
    assert heading(_job(JobState.queued, queue_position=1), stage_times([]), NOW).text == (
        "Waiting for the gateway's worker"
    )
