"""What the gateway does when an analysis is stored: the wound's healing track and decision support follow.

The analysis jobs publish the fact (gateway/jobs/events.py); the composition root hands these reactions to the
workers. The order matters: decision support reads the track the first reaction wrote.
"""

from __future__ import annotations

from gateway.jobs.events import AnalysisStored, Reaction
from gateway.jobs.timeline import update_track
from gateway.records.decision_support import refresh_patient
from gateway.storage.database import Database
from schemas.config import Config


def healing_track(db: Database, config: Config, event: AnalysisStored) -> None:
    update_track(db, config, event.patient_id, event.wound_id)


def decision_support(db: Database, config: Config, event: AnalysisStored) -> None:
    refresh_patient(db, config, event.patient_id)


ANALYSIS_STORED: tuple[Reaction, ...] = (healing_track, decision_support)
