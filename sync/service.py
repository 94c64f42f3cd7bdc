"""The clinic's store-and-forward as the gateway uses it: queue a case, run a round when due, report status.

Rounds are driven by the gateway's APScheduler job every [sync] interval_s. After a failed round the next one
waits retry_base_s x 2^(failures-1), capped at retry_max_s, with full random jitter (so many clinics coming back
after an outage do not all call at once); a clinician queueing a case starts a round at once.
"""

from __future__ import annotations

import datetime as dt
import logging
import random
import threading
from collections.abc import Callable

import msgspec

from base.folders import keys_dir
from base.storage import audit
from base.storage.database import Database
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.encounter_snapshot import EncounterSnapshot
from schemas.errors import BurnedgeError
from schemas.transfer import LinkSettings, OutboxEntry, SyncStatus
from sync import peers
from sync.anchor import anchor_path, load_anchor
from sync.bundle import PartData
from sync.keys import SiteKeys, load_keys
from sync.outbox import Outbox
from sync.sender import RoundReport, Sender
from sync.storage import outbox as outbox_store
from sync.storage import state as sync_state
from sync.wire import LinkDown

log = logging.getLogger("burnedge.sync")


class SyncService:
    def __init__(self, db: Database, config: Config):
        self.db = db
        self.config = config
        self.outbox = Outbox(db, config)
        self._round_lock = threading.Lock()

    def keys(self) -> SiteKeys:
        return load_keys(keys_dir(self.config))

    def link_settings(self) -> LinkSettings | None:
        """The link as set on the Burn center page, if it ever was."""
        return sync_state.link_settings(self.db.connection())

    def set_link(self, settings: LinkSettings, user_id: str | None, device_id: str | None = None) -> None:
        """Store the link, audited; the next round (scheduled or asked for) uses it."""
        endpoints = ", ".join(settings.center_endpoints) or "no address"
        with self.db.write() as conn:
            sync_state.put_link_settings(conn, settings)
            # A new link deserves a try now, not after the backoff of the old one's failures.
            sync_state.put_round_values(conn, {"failures": "0"}, clear=("next_round_at",))
            audit.append(
                conn,
                action="sync.link",
                user_id=user_id,
                device_id=device_id,
                kind="site",
                detail=f"link {'on' if settings.enabled else 'off'}, burn center at {endpoints}, by {settings.set_by}",
            )

    def effective_config(self, settings: LinkSettings | None = None) -> Config:
        """The configuration with the Burn center page's link (`settings`, else as stored) in place of [sync]
        enabled and center_endpoints."""
        settings = settings or self.link_settings()
        if settings is None:
            return self.config
        sync = msgspec.structs.replace(
            self.config.sync, enabled=settings.enabled, center_endpoints=list(settings.center_endpoints)
        )
        return msgspec.structs.replace(self.config, sync=sync)

    def queue(
        self,
        encounter: Callable[[], EncounterSnapshot],
        user: str,
        extra: Callable[[EncounterSnapshot], tuple[PartData, ...]] = lambda _: (),
    ) -> OutboxEntry:
        """Queue the encounter as `encounter()` reads it, with `extra` made from that reading (Outbox.queue)."""
        return self.outbox.queue(self.keys(), encounter, user, extra)

    def run_round(self, *, force: bool = False) -> RoundReport | None:
        """One round unless the backoff says wait (`force` ignores it); None when skipped or already running."""
        if not force and not self._due():
            return None
        if not self._round_lock.acquire(blocking=False):
            return None
        try:
            report = Sender(self.db, self.effective_config(), self.keys()).run_round()
        except BurnedgeError as exc:
            self._failed(exc.detail)
            log.warning("sync round failed: %s", exc.detail)
            if not isinstance(exc, LinkDown):
                raise
            return None
        finally:
            self._round_lock.release()
        self._succeeded(report)
        if report.delivered or report.notes_received or report.rejected:
            log.info(
                "sync round: %d delivered, %d notes received, %d rejected",
                len(report.delivered),
                report.notes_received,
                len(report.rejected),
            )
        return report

    def scheduled_round(self, force: bool = False) -> None:
        """For the scheduler, while the link is enabled: a failure is recorded (status, backoff) and logged, never
        raised."""
        if not self.effective_config().sync.enabled:
            return
        try:
            self.run_round(force=force)
        except BurnedgeError:
            pass  # run_round recorded and logged it

    def status(self) -> SyncStatus:
        conn = self.db.connection()
        state = sync_state.round_state(conn)
        counts = outbox_store.counts(conn)
        try:
            site_id = self.keys().site_id
        except BurnedgeError:
            site_id = None
        settings = self.link_settings()
        config = self.effective_config(settings)
        try:
            center_id = peers.only_center(conn, self.config.sync.center_id).site_id
        except BurnedgeError:
            center_id = None
        try:
            kept = load_anchor(anchor_path(self.config), None)
        except BurnedgeError:
            kept = None  # audit verify names a damaged anchor; the status only reports a good one
        return SyncStatus(
            enabled=config.sync.enabled,
            site_id=site_id,
            center_id=center_id,
            queued=counts.queued,
            delivered=counts.delivered,
            last_round_at=state.last_round_at,
            last_success_at=state.last_success_at,
            last_error=state.last_error,
            next_round_at=state.next_round_at,
            failures_in_a_row=state.failures,
            audit_anchored_seq=kept.head.seq if kept else None,
            audit_anchored_at=kept.anchored_at if kept else None,
            audit_anchor_problem=state.audit_anchor_problem,
            center_endpoints=list(config.sync.center_endpoints),
            link_set_by=settings.set_by if settings else None,
            link_set_at=settings.set_at if settings else None,
        )

    # backoff state ----------------------------------------------------------------
    def _due(self) -> bool:
        nxt = sync_state.round_state(self.db.connection()).next_round_at
        return nxt is None or dt.datetime.fromisoformat(nxt) <= utcnow()

    def _failed(self, reason: str) -> None:
        failures = sync_state.round_state(self.db.connection()).failures + 1
        cap = min(self.config.sync.retry_max_s, self.config.sync.retry_base_s * 2 ** (failures - 1))
        wait = random.uniform(0, cap)
        now = utcnow()
        self._put(
            last_round_at=iso(now),
            last_error=reason,
            failures=str(failures),
            next_round_at=iso(now + dt.timedelta(seconds=wait)),
        )

    def _succeeded(self, report: RoundReport) -> None:
        now = iso(utcnow())
        problem = {"audit_anchor_problem": report.anchor_problem} if report.anchor_problem else {}
        clear = ("last_error",) if problem else ("last_error", "audit_anchor_problem")
        self._put(last_round_at=now, last_success_at=now, failures="0", next_round_at=now, clear=clear, **problem)

    def _put(self, clear: tuple[str, ...] = (), **values: str) -> None:
        with self.db.write() as conn:
            sync_state.put_round_values(conn, values, clear)
