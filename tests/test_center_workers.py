"""Several center workers behind one Zenoh router (center/workers.py), over real Zenoh sessions on loopback and a
real PostgreSQL database: each clinic is answered by one worker, the clinics are shared out, and when a worker
stops in the middle of a transfer another one finishes it from the chunks already stored."""

from __future__ import annotations

import json
import threading
import time
import uuid
from pathlib import Path

import msgspec
import pytest
import zenoh

from base.folders import center_store_dir
from center.app import open_center_db
from center.endpoint import Endpoint
from center.receiver import Receiver
from center.router import serve_router
from center.workers import owner
from harness.center_bundles import make_bundle
from harness.processes import free_port
from harness.sites import wait_for
from schemas.config import CentralConfig, SyncConfig
from schemas.transfer import AnnounceReply, CommitReply, SiteRole
from sync import peers
from sync.keys import init_keys
from sync.wire import LinkDown, request
from sync.zenoh_link import Keys, open_clinic_session

CLINICS = 8


@pytest.fixture
def center(tmp_path: Path, postgres_server):
    port = free_port()
    central = CentralConfig(
        database=postgres_server.create_database("workers"),
        store_dir=str(tmp_path / "store"),
        keys_dir=str(tmp_path / "center-keys"),
        listen_endpoints=[f"tcp/127.0.0.1:{port}"],
        router_endpoints=[f"tcp/127.0.0.1:{port}"],
    )
    keys = init_keys(tmp_path / "center-keys", "center-a", SiteRole.center, "Center")
    db = open_center_db(central)
    clinics = [init_keys(tmp_path / f"c{i}", f"clinic-{i}", SiteRole.clinic, f"Clinic {i}") for i in range(CLINICS)]
    for clinic in clinics:
        peers.enrol(db, clinic.identity, by="it")
    stop = threading.Event()
    router = threading.Thread(target=serve_router, args=(central, stop), daemon=True)
    router.start()
    time.sleep(0.3)
    yield central, db, keys, clinics
    stop.set()
    router.join(10)
    db.close()


def worker(central: CentralConfig, db, keys) -> Endpoint:
    return Endpoint(db, central, Receiver(db, central, keys, center_store_dir(central))).__enter__()


def clinic_session(central: CentralConfig):
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("connect/endpoints", json.dumps(central.router_endpoints))
    conf.insert_json5("scouting/multicast/enabled", "false")
    return zenoh.open(conf)


def live_workers(endpoints: list[Endpoint], count: int) -> None:
    wait_for(lambda: all(len(e._share.live) == count for e in endpoints), 10, f"{count} workers to see each other")


def test_clinics_are_shared_out_and_each_is_answered_by_one_worker(center):
    central, db, keys, clinics = center
    first, second = worker(central, db, keys), worker(central, db, keys)
    try:
        live_workers([first, second], 2)
        answered: dict[str, set[str]] = {}
        for endpoint in (first, second):
            original = endpoint._answer

            def spy(query, endpoint=endpoint, original=original):
                site = str(query.key_expr).split("/")[3]
                answered.setdefault(site, set()).add(endpoint._share.worker_id)
                original(query)

            endpoint._answer = spy
        link = Keys(central.key_prefix, keys.site_id)
        with clinic_session(central) as session:
            for clinic in clinics:
                _, envelope, _ = make_bundle(clinic, keys.identity, str(uuid.uuid4()), 1)
                reply = msgspec.msgpack.decode(request(session, link.announce(clinic.site_id), envelope, 10))
                assert reply["status"] == "send"
        ids = {first._share.worker_id, second._share.worker_id}
        assert {site: len(by) for site, by in answered.items()} == {c.site_id: 1 for c in clinics}
        expected = {c.site_id: {owner(ids, c.site_id)} for c in clinics}
        assert answered == expected
        assert len({next(iter(by)) for by in answered.values()}) == 2  # 8 clinics, 2 workers: both have some
    finally:
        first.__exit__(None, None, None)
        second.__exit__(None, None, None)


def test_a_worker_stopping_mid_transfer_leaves_the_rest_to_another_which_stores_the_case_once(center):
    central, db, keys, clinics = center
    workers = [worker(central, db, keys), worker(central, db, keys)]
    live_workers(workers, 2)
    ids = {w._share.worker_id for w in workers}
    clinic = clinics[0]
    serving = next(w for w in workers if w._share.worker_id == owner(ids, clinic.site_id))
    other = next(w for w in workers if w is not serving)
    link = Keys(central.key_prefix, keys.site_id)
    bundle_id, envelope, sealed = make_bundle(clinic, keys.identity, str(uuid.uuid4()), 1, chunk_size=1024)
    try:
        with clinic_session(central) as session:
            assert msgspec.msgpack.decode(request(session, link.announce(clinic.site_id), envelope, 10))["status"]
            half = len(sealed.chunks) // 2
            for i, (ref, data) in enumerate(zip(sealed.refs[:half], sealed.chunks[:half], strict=True)):
                request(session, link.chunk(clinic.site_id, bundle_id, i, ref.sha256), data, 10)
            serving.__exit__(None, None, None)  # its session closes: the router drops its queryables at once
            live_workers([other], 1)

            again = msgspec.msgpack.decode(
                request(session, link.announce(clinic.site_id), envelope, 10), type=AnnounceReply
            )
            assert again.status == "send" and sorted(again.held) == list(range(half))
            for i in range(half, len(sealed.chunks)):
                request(session, link.chunk(clinic.site_id, bundle_id, i, sealed.refs[i].sha256), sealed.chunks[i], 10)
            done = msgspec.msgpack.decode(
                request(session, link.commit(clinic.site_id, bundle_id), b"", 10), type=CommitReply
            )
        assert done.status == "stored" and done.receipt is not None
        rows = db.connection().execute("SELECT COUNT(*) FROM bundles WHERE bundle_id = ?", (bundle_id,)).fetchone()
        assert rows[0] == 1
    finally:
        other.__exit__(None, None, None)


def test_a_clinic_listing_several_endpoints_reaches_the_center_through_the_first_that_answers(center):
    central, db, keys, clinics = center
    endpoint = worker(central, db, keys)
    dead = f"tcp/127.0.0.1:{free_port()}"
    link = Keys(central.key_prefix, keys.site_id)
    try:
        sync = SyncConfig(center_endpoints=[dead, *central.router_endpoints], connect_timeout_s=2)
        with open_clinic_session(sync) as session:
            _, envelope, _ = make_bundle(clinics[0], keys.identity, str(uuid.uuid4()), 1)
            assert msgspec.msgpack.decode(request(session, link.announce(clinics[0].site_id), envelope, 10))
        with pytest.raises(LinkDown, match=dead.split("/")[1]):
            open_clinic_session(SyncConfig(center_endpoints=[dead], connect_timeout_s=0.5))
    finally:
        endpoint.__exit__(None, None, None)
