"""Zenoh sessions and key expressions, in one place.

A clinic opens a client session that connects out to the center's endpoints (it sits behind NAT); the center
listens as a router. Either starts from an optional Zenoh JSON5 file (TLS certificates, transport tuning) with
the endpoints and mode from burnedge's own config laid over it. Multicast scouting is off: sites are found by
their configured endpoints only, never by whoever answers on the local network. Shared memory is off too.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import zenoh

from schemas.config import CentralConfig, SyncConfig
from schemas.errors import InvalidInput
from sync.wire import LinkDown


def _base(path: str) -> zenoh.Config:
    if not path:
        return zenoh.Config()
    try:
        return zenoh.Config.from_file(path)
    except Exception as exc:  # zenoh raises its own ZError for unreadable or invalid files
        raise InvalidInput(f"Zenoh config file {path} could not be read: {exc}") from exc


def _set(conf: zenoh.Config, key: str, value) -> None:
    try:
        conf.insert_json5(key, json.dumps(value))
    except Exception as exc:
        raise InvalidInput(f"Zenoh setting {key} = {value!r} is not valid: {exc}") from exc


def clinic_session_config(sync: SyncConfig, endpoint: str) -> zenoh.Config:
    """A clinic's session to one of the center's endpoints, retried for up to connect_timeout_s."""
    conf = _base(sync.zenoh_config)
    _set(conf, "mode", "client")
    _set(conf, "connect/endpoints", [endpoint])
    _set(conf, "connect/timeout_ms", int(sync.connect_timeout_s * 1000))
    _set(conf, "connect/exit_on_failure", True)
    _no_discovery_no_shm(conf)
    return conf


def open_clinic_session(sync: SyncConfig):
    """A session to the first of the center's endpoints that answers, tried in the configured order (Zenoh itself,
    given several with a timeout, keeps retrying the first until the timeout). LinkDown when none does."""
    if not sync.center_endpoints:
        raise InvalidInput(
            "[sync] center_endpoints is empty: set the burn center's Zenoh endpoint, e.g. tcp/203.0.113.5:7447"
        )
    problems = []
    for endpoint in sync.center_endpoints:
        try:
            return zenoh.open(clinic_session_config(sync, endpoint))
        except zenoh.ZError as exc:
            problems.append(f"{endpoint}: {str(exc).split(' at /')[0]}")
    raise LinkDown(f"cannot reach the burn center ({'; '.join(problems)})")


def _no_discovery_no_shm(conf: zenoh.Config) -> None:
    _set(conf, "scouting/multicast/enabled", False)
    # A clinic and its center are never one machine. On one machine (tests, benchmarks) Zenoh would pass large
    # payloads through shared memory and bypass the network that store-and-forward exists for.
    _set(conf, "transport/shared_memory/enabled", False)


def center_session_config(central: CentralConfig) -> zenoh.Config:
    """A center worker's session: a client of the configured routers, or, with none, the router itself."""
    if not central.router_endpoints:
        return router_session_config(central)
    conf = _base(central.zenoh_config)
    _set(conf, "mode", "client")
    _set(conf, "connect/endpoints", list(central.router_endpoints))
    _no_discovery_no_shm(conf)
    return conf


def router_session_config(central: CentralConfig) -> zenoh.Config:
    """The center's router (`burnedge central router`, or a worker that is its own): clinics and workers connect."""
    conf = _base(central.zenoh_config)
    _set(conf, "mode", "router")
    _set(conf, "listen/endpoints", list(central.listen_endpoints))
    _no_discovery_no_shm(conf)
    return conf


@dataclass(frozen=True)
class Keys:
    """The key expressions of one center: `{prefix}/{center_id}/{verb}/...`."""

    prefix: str
    center_id: str

    @property
    def all(self) -> str:
        return f"{self.prefix}/{self.center_id}/**"

    def site(self, site_id: str) -> str:
        """Every request from one clinic (the verb comes first, the site second)."""
        return f"{self.prefix}/{self.center_id}/*/{site_id}/**"

    @property
    def workers(self) -> str:
        """The liveliness tokens of the center's workers."""
        return f"{self.prefix}/workers/{self.center_id}/*"

    def worker(self, worker_id: str) -> str:
        return f"{self.prefix}/workers/{self.center_id}/{worker_id}"

    def announce(self, site_id: str) -> str:
        return f"{self.prefix}/{self.center_id}/announce/{site_id}"

    def chunk(self, site_id: str, bundle_id: str, index: int, sha256: str) -> str:
        return f"{self.prefix}/{self.center_id}/chunk/{site_id}/{bundle_id}/{index}/{sha256}"

    def commit(self, site_id: str, bundle_id: str) -> str:
        return f"{self.prefix}/{self.center_id}/commit/{site_id}/{bundle_id}"

    def anchor(self, site_id: str) -> str:
        return f"{self.prefix}/{self.center_id}/anchor/{site_id}"

    def mail(self, site_id: str) -> str:
        return f"{self.prefix}/{self.center_id}/mail/{site_id}"

    def parse(self, key: str) -> tuple[str, list[str]]:
        """The verb and the rest of a key under this center; raises ValueError for anything else."""
        head = f"{self.prefix}/{self.center_id}/"
        if not key.startswith(head):
            raise ValueError(f"key {key} is not under {head}")
        verb, *rest = key[len(head) :].split("/")
        return verb, rest
