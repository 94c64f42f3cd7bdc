"""The center's Zenoh endpoint: the requests under `{prefix}/{center_id}/**` this worker answers (all of them for
a center of one worker; its share of the clinics among several, center/workers.py), from a thread pool.

Every refusal is logged with its reason, recorded in the `rejections` table and told to the sender; the
endpoint goes on answering everything else.
"""

from __future__ import annotations

import logging
import re
from concurrent.futures import ThreadPoolExecutor

import msgspec
import zenoh

from base.storage.postgres import AnyDatabase
from center.anchors import AnchorBook
from center.receiver import Receiver
from center.storage import rejections
from center.workers import WorkerShare
from schemas.base import ID_PATTERN, iso, utcnow
from schemas.config import CentralConfig
from schemas.errors import BurnedgeError, TransferRejected
from schemas.transfer import SITE_ID_PATTERN
from sync.wire import LinkDown, refusal
from sync.zenoh_link import Keys, center_session_config

log = logging.getLogger("burnedge.central")
_SITE = re.compile(SITE_ID_PATTERN)
_ID = re.compile(ID_PATTERN)
_SHA = re.compile(r"\A[0-9a-f]{64}\Z")


class Endpoint:
    def __init__(self, db: AnyDatabase, config: CentralConfig, receiver: Receiver):
        self.db = db
        self.config = config
        self.receiver = receiver
        self.anchors = AnchorBook(db, receiver.keys, receiver.verified)
        self.link = Keys(config.key_prefix, receiver.keys.site_id)
        self._session = None
        self._share: WorkerShare | None = None
        self._pool: ThreadPoolExecutor | None = None

    def __enter__(self) -> Endpoint:
        self._pool = ThreadPoolExecutor(self.config.handler_threads, thread_name_prefix="central")
        try:
            self._session = zenoh.open(center_session_config(self.config))
        except zenoh.ZError as exc:
            self._pool.shutdown()
            if self.config.router_endpoints:
                where = f"reach the center's Zenoh router at {', '.join(self.config.router_endpoints)}"
            else:
                where = f"listen on {', '.join(self.config.listen_endpoints)}"
            raise LinkDown(f"cannot {where}: {str(exc).split(' at /')[0]}") from exc
        self._share = WorkerShare(self._session, self.link, self.db, self._on_query, self.config.worker_id).__enter__()
        if self.config.router_endpoints:
            log.info("center %s worker connected to %s", self.link.center_id, ", ".join(self.config.router_endpoints))
        else:
            log.info("center %s listening on %s", self.link.center_id, ", ".join(self.config.listen_endpoints))
        return self

    def __exit__(self, *exc) -> None:
        if self._share is not None:
            self._share.__exit__(*exc)
        if self._pool is not None:
            self._pool.shutdown(wait=True)
        if self._session is not None:
            self._session.close()

    def _on_query(self, query) -> None:
        self._pool.submit(self._answer, query)

    def _answer(self, query) -> None:
        key = str(query.key_expr)
        site_id = None
        try:
            payload = query.payload.to_bytes() if query.payload is not None else b""
            verb, rest = self._parse(key)
            site_id = rest[0]
            query.reply(query.key_expr, self._dispatch(verb, rest, payload))
        except TransferRejected as exc:
            self._rejected(key, site_id, exc)
            query.reply_err(refusal(exc))
        except BurnedgeError as exc:  # the center's own trouble (database busy): the clinic retries later
            log.warning("could not answer %s: %s", key, exc.detail)
            query.reply_err(refusal(TransferRejected(f"the center could not answer now: {exc.detail}", code="busy")))
        except Exception:
            log.exception("unexpected error answering %s", key)
            query.reply_err(refusal(TransferRejected("the center failed on this request", code="internal")))
        finally:
            query.drop()

    def _parse(self, key: str) -> tuple[str, list[str]]:
        try:
            verb, rest = self.link.parse(key)
        except ValueError as exc:
            raise TransferRejected(str(exc), code="garbage") from exc
        shapes = {"announce": 1, "chunk": 4, "commit": 2, "mail": 1, "anchor": 1}
        if shapes.get(verb) != len(rest) or not _SITE.match(rest[0]):
            raise TransferRejected(f"no such request: {key}", code="garbage")
        if len(rest) > 1 and not _ID.match(rest[1]):
            raise TransferRejected(f"{rest[1]!r} is not a bundle id", code="garbage")
        if verb == "chunk" and (not rest[2].isdigit() or not _SHA.match(rest[3])):
            raise TransferRejected(f"chunk key {key} needs an index and a sha256", code="garbage")
        return verb, rest

    def _dispatch(self, verb: str, rest: list[str], payload: bytes) -> bytes:
        if verb == "announce":
            return msgspec.msgpack.encode(self.receiver.announce(rest[0], payload))
        if verb == "chunk":
            self.receiver.chunk(rest[0], rest[1], int(rest[2]), rest[3], payload)
            return b"ok"
        if verb == "commit":
            return msgspec.msgpack.encode(self.receiver.commit(rest[0], rest[1]))
        if verb == "anchor":
            return msgspec.msgpack.encode(self.anchors.anchor(rest[0], payload))
        return msgspec.msgpack.encode(self.receiver.mail(rest[0], payload))

    def _rejected(self, key: str, site_id: str | None, exc: TransferRejected) -> None:
        log.warning("rejected %s (%s): %s", key, exc.code, exc.detail)
        try:
            with self.db.write() as conn:
                rejections.record_rejection(
                    conn, at=iso(utcnow()), site_id=site_id, code=exc.code, reason=exc.detail, key=key[:500]
                )
        except BurnedgeError as exc2:
            log.warning("could not record the rejection: %s", exc2.detail)
