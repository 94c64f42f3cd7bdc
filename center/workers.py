"""Several center workers behind one Zenoh router, sharing the clinics among them.

Each worker holds a liveliness token, so every worker knows which are alive. A clinic belongs to the live worker that
rendezvous hashing picks for its site id; that worker declares a *complete* queryable on the clinic's requests, and
Zenoh routes a query to a complete queryable that covers it when there is one (QueryTarget.BEST_MATCHING, the
default). Every worker also declares one catch-all queryable, not complete: it receives what no complete queryable
covers (a clinic enrolled since the last look, or one whose worker has just stopped), and answers only what it owns.
When a worker stops, its token goes, the others recompute and declare its clinics (the catch-all answers them until
the router knows); a request caught in between gets no answer and the clinic retries it. Any worker can finish any
transfer: they share the database and the store.
"""

from __future__ import annotations

import hashlib
import logging
import os
import secrets
import socket
import threading
import time
from collections.abc import Callable

import zenoh

from base.storage.postgres import AnyDatabase
from schemas.transfer import SiteRole
from sync.storage.peers import unrevoked_ids
from sync.zenoh_link import Keys

log = logging.getLogger("burnedge.central")
REFRESH_S = 10.0
"""How often a worker looks again at the enrolled clinics (a newly enrolled one is answered by the catch-all)."""
HANDOVER_S = 3.0
"""How long the catch-all goes on answering a clinic after this worker declared its queryable for it, until the
router has learnt of it: a request answered twice meanwhile is harmless (every step is idempotent), one left
unanswered costs the clinic a retry."""


def owner(workers: set[str], site_id: str) -> str:
    """The worker that answers a clinic: the same on every worker that sees the same live workers."""
    return max(workers, key=lambda w: hashlib.sha256(f"{w}\0{site_id}".encode()).digest())


class WorkerShare:
    def __init__(self, session, link: Keys, db: AnyDatabase, answer: Callable, worker_id: str = ""):
        self.session = session
        self.link = link
        self.db = db
        self.answer = answer
        self.worker_id = worker_id or f"{socket.gethostname()}-{os.getpid()}-{secrets.token_hex(3)}"
        self.live: set[str] = {self.worker_id}
        self._owned: dict[str, tuple[object, float]] = {}
        """Clinics this worker declared a queryable for: the queryable and when."""
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._declared: list = []

    def __enter__(self) -> WorkerShare:
        liveliness = self.session.liveliness()
        self._declared.append(liveliness.declare_token(self.link.worker(self.worker_id)))
        self._declared.append(liveliness.declare_subscriber(self.link.workers, self._on_worker, history=True))
        self._declared.append(self.session.declare_queryable(self.link.all, self._on_catch_all, complete=False))
        self.rebalance()
        threading.Thread(target=self._refresh, name="central-share", daemon=True).start()
        log.info("worker %s answering %d clinics", self.worker_id, len(self._owned))
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        with self._lock:
            for queryable, _ in self._owned.values():
                queryable.undeclare()
            self._owned.clear()
        for declared in reversed(self._declared):
            declared.undeclare()

    def owns(self, site_id: str) -> bool:
        return owner(self.live, site_id) == self.worker_id

    def rebalance(self) -> None:
        """Declare a complete queryable for each enrolled clinic this worker owns now, and drop the others."""
        sites = set(unrevoked_ids(self.db.connection(), SiteRole.clinic))
        with self._lock:
            if self._stop.is_set():
                return
            wanted = {s for s in sites if self.owns(s)}
            dropped, added = self._owned.keys() - wanted, wanted - self._owned.keys()
            for site_id in dropped:
                self._owned.pop(site_id)[0].undeclare()
            for site_id in added:
                queryable = self.session.declare_queryable(self.link.site(site_id), self.answer, complete=True)
                self._owned[site_id] = (queryable, time.monotonic())
            count, workers = len(self._owned), len(self.live)
        if dropped or added:
            log.info(
                "worker %s answers %d clinics (%d workers alive; +%d -%d)",
                self.worker_id,
                count,
                workers,
                len(added),
                len(dropped),
            )

    def _on_worker(self, sample) -> None:
        worker_id = str(sample.key_expr).rsplit("/", 1)[-1]
        with self._lock:
            if sample.kind == zenoh.SampleKind.DELETE:
                self.live.discard(worker_id)
            else:
                self.live.add(worker_id)
            self.live.add(self.worker_id)
            count = len(self.live)
        log.info("%d center workers alive (%s %s)", count, worker_id, sample.kind)
        threading.Thread(target=self._rebalance_logged, daemon=True).start()  # not on Zenoh's callback thread

    def _on_catch_all(self, query) -> None:
        try:
            _, rest = self.link.parse(str(query.key_expr))
        except ValueError:
            rest = []
        site_id = rest[0] if rest else str(query.key_expr)
        with self._lock:
            declared = self._owned.get(site_id)
            mine = self.owns(site_id) and (declared is None or time.monotonic() - declared[1] < HANDOVER_S)
        if mine:
            self.answer(query)  # otherwise this worker's own complete queryable, or another worker, answers
        else:
            query.drop()

    def _rebalance_logged(self) -> None:
        try:
            self.rebalance()
        except Exception:
            log.exception("could not share the clinics among the workers; retrying in %g s", REFRESH_S)

    def _refresh(self) -> None:
        while not self._stop.wait(REFRESH_S):
            self._rebalance_logged()
