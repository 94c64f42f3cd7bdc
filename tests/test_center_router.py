"""A burn center of two workers behind `burnedge central router`, each a real process, on one PostgreSQL database,
with a real clinic gateway sending over a throttled link: the worker answering the clinic is SIGKILLed in the
middle of a transfer, the other finishes it, and each case is stored once, byte for byte, its receipt back at the
clinic."""

from __future__ import annotations

from pathlib import Path

import pytest

from center.workers import owner
from harness.processes import free_port
from harness.sites import CLINIC, CenterProcess, RouterProcess, Sites, record_case, wait_for
from tests.test_sync_center import assert_stored_once, delivered, photos_at_center, sent_chunks

pytestmark = pytest.mark.server


def both_alive(*workers: CenterProcess) -> bool:
    return all("2 center workers alive" in w.log.read_text() for w in workers)


def test_sigkill_of_the_worker_answering_a_clinic_mid_transfer_leaves_it_to_the_other(tmp_path: Path, postgres_server):
    from harness.poor_link import ThrottlingProxy

    database = postgres_server.create_database("router")
    router = RouterProcess(tmp_path).start()
    try:
        with ThrottlingProxy("127.0.0.1", router.port, rate_kbit=4000) as proxy:  # ~1 s per 0.5 MB: time to kill
            sites = Sites(
                tmp_path,
                center_endpoint=f"tcp/127.0.0.1:{proxy.port}",
                zenoh_port=router.port,
                center_database=database,
            )
            sites.gateway.env["BURNEDGE_SYNC_CHUNK_KIB"] = "64"
            sites.set_up()
            second = CenterProcess(tmp_path, router.port, free_port(), database, name="center-2")
            workers = {"w1": sites.center, "w2": second}
            for worker_id, process in workers.items():
                process.env.update(
                    {"BURNEDGE_CENTRAL_ROUTER_ENDPOINTS": router.endpoint, "BURNEDGE_CENTRAL_WORKER_ID": worker_id}
                )
            try:
                for process in workers.values():
                    process.start()
                wait_for(lambda: both_alive(*workers.values()), 20, "the two workers to see each other")
                answering = workers[owner(set(workers), CLINIC)]
                sites.gateway.start()
                clinic = sites.clinic_client()
                first, first_photos = record_case(clinic, tmp_path, photos=3, seed=1)
                clinic.http.post(f"/api/v1/encounters/{first}/transfers")
                wait_for(lambda: sent_chunks(clinic, first) >= 4, 60, "the first chunks acknowledged")
                answering.kill()
                one = wait_for(lambda: delivered(clinic, first, 1), 120, "delivery by the other worker")

                answering.start()
                second_case, second_photos = record_case(clinic, tmp_path, photos=3, seed=2)
                clinic.http.post(f"/api/v1/encounters/{second_case}/transfers")
                two = wait_for(lambda: delivered(clinic, second_case, 1), 120, "delivery with both workers back")

                for process in workers.values():  # either worker's API serves every case
                    center = process.client()
                    for entry, photos in ((one, first_photos), (two, second_photos)):
                        assert photos_at_center(center, entry["bundle_id"]) == sorted(p.read_bytes() for p in photos)
            finally:
                sites.gateway.stop()
                for process in workers.values():
                    process.stop()
    finally:
        router.stop()
    assert_stored_once(sites.center, [one["bundle_id"], two["bundle_id"]])
