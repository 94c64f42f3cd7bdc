"""What an analysis job tells the rest of the gateway: the fact that an analysis was stored.

The runner publishes the fact; it does not know who listens. The gateway's composition root (gateway/app.py for
`burnedge serve`, the CLI for `burnedge worker`) hands the reactions down to the workers, which pass them to each
job's process: the healing track and decision support react (gateway/reactions.py). Reactions are
module-level functions, so they cross the process boundary by name.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

import msgspec

from gateway.storage.database import Database
from schemas.config import Config

log = logging.getLogger("burnedge.jobs")


class AnalysisStored(msgspec.Struct, frozen=True, kw_only=True):
    """A finished measurement was stored as the burn_analysis record `job_id`."""

    job_id: str
    encounter_id: str
    patient_id: str
    wound_id: str | None = None
    """The wound measured; None for a patient with no wound recorded."""


Reaction = Callable[[Database, Config, AnalysisStored], None]
"""Something done because an analysis was stored; it may fail without undoing the analysis."""


def publish(reactions: Sequence[Reaction], db: Database, config: Config, event: AnalysisStored) -> None:
    """Run every reaction; one that fails is logged and the others still run (the analysis stays stored)."""
    for react in reactions:
        try:
            react(db, config, event)
        except Exception:
            log.exception("analysis %s stored, but %s failed", event.job_id, getattr(react, "__qualname__", react))
