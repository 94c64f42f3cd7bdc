"""Store-and-forward to the burn center: throughput on loopback and time over a 256 kbit/s link.

    .venv/bin/python -m benchmarks.sync_transfer [--mb 5] [--repeat 3] [--chunk-kib 128] [--window 8]
                                                [--skip-slow] [--json out.json]

Same run, same machine:
(a) loopback: a clinic in this process (sync.outbox.Outbox + sync.sender.Sender) sends an encrypted case bundle of
    about --mb MB to a real center process (`burnedge central`), from queueing (snapshot + sealing + chunk files)
    to the verified receipt; next to a raw Zenoh put of the same number of bytes, in chunks of the same size, from
    a client session to a subscriber on a router session (shared memory and multicast scouting off, as in
    sync/zenoh_link.py). Median of --repeat runs. Goal: the bundle at >= 50 % of the raw put's MB/s.
(b) slow link: a ~5 MB bundle over 256 kbit/s (two network namespaces when available, else a throttling proxy on
    loopback), no cuts, with the poor-link test's settings; next to the ideal time, encrypted bytes x 8 / 256000.
    Goal: <= 1.3x.
No timing asserts: the figures are printed (and written with --json).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import os
import platform
import statistics
import tempfile
import threading
import time
from functools import partial
from pathlib import Path

import msgspec
import zenoh

from base.folders import keys_dir
from gateway.records.snapshot import current_snapshot
from gateway.storage.database import Database
from harness.processes import FAST_HASH_ENV, free_port
from harness.sites import Sites, record_case
from schemas.config import load_config
from sync.keys import load_keys
from sync.outbox import Outbox
from sync.sender import Sender
from sync.zenoh_link import _no_discovery_no_shm, _set

PHOTO_SIZE = (1500, 1120)  # ~1.3 MB of JPEG each
PHOTO_MB = 1.3


def record_cases(sites: Sites, work: Path, count: int, mb: float) -> list[str]:
    """`count` encounters of about `mb` MB of photos each, through the clinic's HTTP API (then stopped)."""
    sites.gateway.start()
    try:
        client = sites.clinic_client()
        ids = []
        for n in range(count):
            photos = max(1, math.ceil(mb / PHOTO_MB))
            ids.append(record_case(client, work, photos, seed=10 * n, size=PHOTO_SIZE)[0])
        return ids
    finally:
        sites.gateway.stop()


def bundle_runs(sites: Sites, encounter_ids: list[str], chunk_kib: int, window: int) -> list[dict]:
    env = {
        **FAST_HASH_ENV,
        **sites.gateway.env,
        "BURNEDGE_GATEWAY_DATABASE": str(sites.gateway.db),
        "BURNEDGE_SYNC_CHUNK_KIB": str(chunk_kib),
        "BURNEDGE_SYNC_WINDOW_CHUNKS": str(window),
    }
    config = load_config(environ=env)
    db = Database.from_config(config.gateway)
    keys = load_keys(keys_dir(config))
    runs = []
    try:
        for encounter_id in encounter_ids:
            t0 = time.perf_counter()
            entry = Outbox(db, config).queue(
                keys, partial(current_snapshot, db, config, encounter_id, "bench"), "bench"
            )
            t1 = time.perf_counter()
            report = Sender(db, config, keys).run_round()
            t2 = time.perf_counter()
            if report.delivered != [entry.bundle_id]:
                raise RuntimeError(f"bundle {entry.bundle_id} not delivered: {report}")
            runs.append(
                {
                    "bytes": entry.bytes,
                    "chunks": entry.chunks,
                    "queue_s": t1 - t0,
                    "send_s": t2 - t1,
                    "total_s": t2 - t0,
                }
            )
    finally:
        db.close()
    return runs


def raw_put_runs(nbytes: int, chunk: int, repeat: int) -> list[float]:
    """Seconds for `nbytes` put in `chunk`-byte payloads from a client session to a router's subscriber."""
    port = free_port()
    router = zenoh.Config()
    _set(router, "mode", "router")
    _set(router, "listen/endpoints", [f"tcp/127.0.0.1:{port}"])
    _no_discovery_no_shm(router)
    client = zenoh.Config()
    _set(client, "mode", "client")
    _set(client, "connect/endpoints", [f"tcp/127.0.0.1:{port}"])
    _no_discovery_no_shm(client)
    got = {"n": 0, "want": 0}
    done = threading.Event()

    def on_sample(sample) -> None:
        got["n"] += len(sample.payload.to_bytes())
        if got["n"] >= got["want"]:
            done.set()

    payload = os.urandom(chunk)
    times = []
    with zenoh.open(router) as center, zenoh.open(client) as clinic:
        sub = center.declare_subscriber("bench/raw/**", on_sample)
        pub = clinic.declare_publisher("bench/raw/x", congestion_control=zenoh.CongestionControl.BLOCK)
        time.sleep(0.5)  # the subscription reaches the client
        for attempt in range(repeat + 1):  # the first is a warm-up
            got["n"], got["want"] = 0, nbytes
            done.clear()
            t0 = time.perf_counter()
            sent = 0
            while sent < nbytes:
                pub.put(payload[: min(chunk, nbytes - sent)])
                sent += min(chunk, nbytes - sent)
            if not done.wait(120):
                raise RuntimeError(f"the subscriber got {got['n']} of {nbytes} bytes")
            if attempt:
                times.append(time.perf_counter() - t0)
        pub.undeclare()
        sub.undeclare()
    return times


def loopback(work: Path, mb: float, repeat: int, chunk_kib: int, window: int) -> dict:
    sites = Sites(work)
    sites.set_up()
    sites.center.start()
    try:
        ids = record_cases(sites, work, repeat + 1, mb)
        runs = bundle_runs(sites, ids, chunk_kib, window)[1:]  # the first is a warm-up
    finally:
        sites.stop()
    nbytes = runs[0]["bytes"]
    raw = raw_put_runs(nbytes, chunk_kib * 1024, repeat)
    med = {k: statistics.median(r[k] for r in runs) for k in ("queue_s", "send_s", "total_s")}
    raw_s = statistics.median(raw)
    return {
        "bytes": nbytes,
        "chunks": runs[0]["chunks"],
        "chunk_kib": chunk_kib,
        "window_chunks": window,
        "bundle_queue_s": med["queue_s"],
        "bundle_send_s": med["send_s"],
        "bundle_total_s": med["total_s"],
        "bundle_mb_s": nbytes / med["total_s"] / 1e6,
        "bundle_send_only_mb_s": nbytes / med["send_s"] / 1e6,
        "raw_put_s": raw_s,
        "raw_put_mb_s": nbytes / raw_s / 1e6,
        "ratio": raw_s / med["total_s"],
        "runs": runs,
        "raw_runs_s": raw,
    }


def slow_link(work: Path) -> dict:
    import sqlite3

    from harness.poor_link_sites import RATE_KBIT, outbox_entry, poor_link, record_and_queue

    with poor_link(work) as (sites, link, start_both):
        _, bundle_id, _ = record_and_queue(sites, work)
        row = outbox_entry(sites.gateway.db, bundle_id)
        t0 = time.monotonic()
        procs = start_both()
        first_ack = None
        while row.state != "delivered":
            if any(p.poll() is not None for p in procs) or time.monotonic() - t0 > 900:
                raise RuntimeError(f"not delivered: {msgspec.structs.asdict(row)}")
            if first_ack is None and row.sent_chunks > 0:
                first_ack = time.monotonic() - t0
            time.sleep(0.2)
            row = outbox_entry(sites.gateway.db, bundle_id)
        took = time.monotonic() - t0
        kind = type(link).__name__
    with sqlite3.connect(sites.center.env["BURNEDGE_CENTRAL_DATABASE"]) as db:
        assert db.execute("SELECT COUNT(*) FROM bundles").fetchone()[0] == 1
    ideal = row.bytes * 8 / (RATE_KBIT * 1000)
    return {
        "link": kind,
        "rate_kbit": RATE_KBIT,
        "bytes": row.bytes,
        "chunks": row.chunks,
        "delivered_s": took,
        "first_progress_s": first_ack,
        "ideal_s": ideal,
        "ratio": took / ideal,
        "attempts": row.attempts,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--mb", type=float, default=5.0, help="bundle size for the loopback measurement")
    parser.add_argument("--repeat", type=int, default=3, help="measured runs of each (median reported)")
    parser.add_argument("--chunk-kib", type=int, default=128, help="[sync] chunk_kib for the loopback bundle")
    parser.add_argument("--window", type=int, default=8, help="[sync] window_chunks for the loopback bundle")
    parser.add_argument("--skip-slow", action="store_true", help="only the loopback measurement")
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args()
    figures: dict = {"date": dt.date.today().isoformat(), "machine": f"{platform.machine()}, {os.cpu_count()} cores"}
    with tempfile.TemporaryDirectory() as tmp:
        lo = figures["loopback"] = loopback(Path(tmp) / "loopback", args.mb, args.repeat, args.chunk_kib, args.window)
    print(
        f"(a) loopback, {lo['bytes'] / 1e6:.2f} MB encrypted in {lo['chunks']} chunks of {lo['chunk_kib']} KiB, "
        f"window {lo['window_chunks']}, median of {args.repeat}"
    )
    print(f"{'':<40}{'seconds':>10}{'MB/s':>10}")
    print(f"{'raw Zenoh put (baseline)':<40}{lo['raw_put_s']:>10.3f}{lo['raw_put_mb_s']:>10.1f}")
    print(f"{'bundle: queue (snapshot, seal, fsync)':<40}{lo['bundle_queue_s']:>10.3f}")
    print(f"{'bundle: send to verified receipt':<40}{lo['bundle_send_s']:>10.3f}{lo['bundle_send_only_mb_s']:>10.1f}")
    print(f"{'bundle: queue to receipt':<40}{lo['bundle_total_s']:>10.3f}{lo['bundle_mb_s']:>10.1f}")
    print(f"bundle / raw put throughput: {lo['ratio']:.0%} (goal >= 50 %)")
    if not args.skip_slow:
        with tempfile.TemporaryDirectory() as tmp:
            sl = figures["slow_link"] = slow_link(Path(tmp) / "slow")
        print(f"(b) {sl['bytes'] / 1e6:.2f} MB over {sl['rate_kbit']} kbit/s ({sl['link']}), no cuts")
        print(f"{'':<40}{'seconds':>10}")
        print(f"{'ideal (bytes x 8 / rate)':<40}{sl['ideal_s']:>10.1f}")
        print(f"{'gateway start to delivered':<40}{sl['delivered_s']:>10.1f}")
        print(f"ratio {sl['ratio']:.2f}x (goal <= 1.3x); first progress saved after {sl['first_progress_s']:.1f} s")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2) + "\n")


if __name__ == "__main__":
    main()
