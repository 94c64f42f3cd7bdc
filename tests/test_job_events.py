"""A stored analysis is published to the reactions the composition root hands down; one that fails does not stop
the others, and the runner names none of them."""

from __future__ import annotations

import ast
import logging

from gateway import reactions
from gateway.jobs import events
from gateway.jobs.events import AnalysisStored
from harness.processes import REPO

EVENT = AnalysisStored(job_id="job-1", encounter_id="enc-1", patient_id="pat-1")


def test_every_reaction_runs_in_order_and_a_failing_one_is_logged_not_raised(caplog):
    seen = []

    def first(db, config, event):
        seen.append(("first", event.patient_id))

    def broken(db, config, event):
        raise RuntimeError("track folder not writable")

    def last(db, config, event):
        seen.append(("last", event.job_id))

    with caplog.at_level(logging.ERROR, logger="burnedge.jobs"):
        events.publish((first, broken, last), db=None, config=None, event=EVENT)
    assert seen == [("first", "pat-1"), ("last", "job-1")]
    assert "analysis job-1 stored, but" in caplog.text and "broken" in caplog.text


def test_the_gateway_reacts_with_the_track_first_then_decision_support():
    assert reactions.ANALYSIS_STORED == (reactions.healing_track, reactions.decision_support)


def test_the_runner_imports_no_service():
    tree = ast.parse((REPO / "gateway" / "jobs" / "runner.py").read_text())
    imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert not [m for m in imported if m and m.startswith(("gateway.records", "gateway.reactions"))]
