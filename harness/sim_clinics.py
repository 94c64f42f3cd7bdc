"""Many clinics without their HTTP servers, for the center's load test and benchmark: each a real gateway database,
its own keys and its own Zenoh client session, recording cases through the gateway's record service and sending
them with the gateway's own outbox and sync round (sync/sender.py), exactly as a clinic does.

    python -m harness.sim_clinics --folder F --first 0 --count 50 --cases 3 --endpoint tcp/127.0.0.1:7447

runs `count` clinics in one process until every case is delivered, and prints one JSON line per case: the clinic,
bundle, size, and the seconds from queued to the center's receipt.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import random
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from base.accounts.permissions import Principal
from base.folders import keys_dir
from gateway.records.service import RecordService
from gateway.records.snapshot import current_snapshot
from gateway.storage.database import Database
from harness.bodies import encounter_body, patient_body
from schemas.accounts import Role
from schemas.config import Config, GatewayConfig, SyncConfig
from schemas.records import RecordKind
from schemas.transfer import SiteIdentity, SiteRole
from sync import peers
from sync.bundle import PartData
from sync.keys import SiteKeys, init_keys, load_keys
from sync.sender import Sender
from sync.service import SyncService
from sync.wire import LinkDown

CLINICIAN = Principal("sim-clinician", "sim", Role.clinician, None, "sim")


def site_id(index: int) -> str:
    return f"sim-clinic-{index:04d}"


class SimClinic:
    def __init__(self, folder: Path, index: int, endpoint: str):
        self.folder = folder / site_id(index)
        self.folder.mkdir(parents=True, exist_ok=True)
        sync = SyncConfig(
            enabled=True, center_endpoints=[endpoint], connect_timeout_s=5, query_timeout_s=30, retry_base_s=0.2
        )
        self.config = Config(gateway=GatewayConfig(database=str(self.folder / "clinic.sqlite3")), sync=sync)
        self.db = Database(self.config.gateway.database)
        self.db.migrate()
        self.sync = SyncService(self.db, self.config)
        self.index = index
        self.queued: dict[str, tuple[float, int, int]] = {}
        """Bundle id: when it was queued (monotonic), its photo's size and seed."""

    def set_up(self, center: SiteIdentity) -> SiteIdentity:
        """Keys made, the center enrolled; the clinic's identity, for the center to enrol."""
        keys = init_keys(keys_dir(self.config), site_id(self.index), SiteRole.clinic, f"Simulated clinic {self.index}")
        peers.enrol(self.db, center, by="load-test")
        return keys.identity

    def keys(self) -> SiteKeys:
        return load_keys(keys_dir(self.config))

    def queue_case(self, photo_bytes: int, seed: int) -> str:
        """A patient, an encounter and one photo of `photo_bytes` random bytes, queued for the center."""
        records = RecordService(self.db, self.config)
        patient = patient_body()
        records.create(CLINICIAN, RecordKind.patient, patient["id"], patient)
        encounter = encounter_body(patient["id"])
        records.create(CLINICIAN, RecordKind.encounter, encounter["id"], encounter)
        photo = random.Random(seed).randbytes(photo_bytes)
        entry = self.sync.queue(
            lambda: current_snapshot(self.db, self.config, encounter["id"], "sim"),
            "sim",
            lambda _: (PartData("photos/case.jpg", photo),),
        )
        self.queued[entry.bundle_id] = (time.monotonic(), photo_bytes, seed)
        return entry.bundle_id

    def round(self, waiting: set[str]) -> list[str]:
        """One sync round; which of the `waiting` bundles the clinic now holds a receipt for (a round cut off by
        the link may have delivered some before it stopped)."""
        try:
            Sender(self.db, self.config, self.keys()).run_round()
        except LinkDown:
            pass
        return [b for b in waiting if self.sync.outbox.get(b).delivered_at is not None]

    def close(self) -> None:
        self.db.close()


def photo_digest(photo_bytes: int, seed: int) -> str:
    return hashlib.sha256(random.Random(seed).randbytes(photo_bytes)).hexdigest()


def run_clinic(clinic: SimClinic, deadline: float, report) -> int:
    """Sync rounds until every queued case of the clinic is delivered (or the deadline); how many are left."""
    waiting = set(clinic.queued)
    while waiting and time.monotonic() < deadline:
        delivered = clinic.round(waiting)
        for bundle_id in delivered:
            queued_at, size, seed = clinic.queued[bundle_id]
            waiting.discard(bundle_id)
            seconds = round(time.monotonic() - queued_at, 3)
            report(
                {
                    "clinic": site_id(clinic.index),
                    "bundle_id": bundle_id,
                    "bytes": size,
                    "seed": seed,
                    "seconds": seconds,
                }
            )
        if waiting and not delivered:
            time.sleep(0.5)  # the link is down or a worker is taking over: the next round resumes
    return len(waiting)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--folder", type=Path, required=True)
    parser.add_argument("--first", type=int, required=True)
    parser.add_argument("--count", type=int, required=True)
    parser.add_argument("--cases", type=int, default=3)
    parser.add_argument("--min-mb", type=float, default=1.0)
    parser.add_argument("--max-mb", type=float, default=5.0)
    parser.add_argument("--endpoint", required=True)
    parser.add_argument("--threads", type=int, default=8, help="clinics syncing at the same time in this process")
    parser.add_argument("--timeout-s", type=float, default=600)
    parser.add_argument("--queue-only", action="store_true", help="set up and queue the cases, send nothing")
    parser.add_argument("--go-file", type=Path, help="wait for this file to exist before sending")
    args = parser.parse_args()
    clinics = [SimClinic(args.folder, i, args.endpoint) for i in range(args.first, args.first + args.count)]
    sizes = random.Random(args.first)
    for clinic in clinics:
        for case in range(args.cases):
            size = int(sizes.uniform(args.min_mb, args.max_mb) * 1_000_000)
            clinic.queue_case(size, seed=clinic.index * 100 + case)
    left = sum(len(c.queued) for c in clinics)
    print(json.dumps({"queued": left}), flush=True)
    if args.go_file is not None:
        while not args.go_file.exists():  # every process sends at once, after all have queued
            time.sleep(0.05)
    started = time.monotonic()
    for clinic in clinics:  # the clock of each case starts when sending starts: all of them wait from then on
        clinic.queued = {b: (started, size, seed) for b, (_, size, seed) in clinic.queued.items()}
    if not args.queue_only:
        lock = threading.Lock()

        def report(line: dict) -> None:
            with lock:
                print(json.dumps(line), flush=True)

        deadline = time.monotonic() + args.timeout_s
        with ThreadPoolExecutor(args.threads) as pool:
            left = sum(pool.map(lambda c: run_clinic(c, deadline, report), clinics))
    for clinic in clinics:
        clinic.close()
    print(json.dumps({"undelivered": left}), flush=True)


if __name__ == "__main__":
    main()
