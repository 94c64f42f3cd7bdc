"""The consultants' case list at a regional center's size: p50/p95 of a page over HTTP at 100,000 stored cases,
on SQLite and on PostgreSQL, next to the whole-list query it replaced on the same database.

    .venv/bin/python -m benchmarks.center_case_list [--cases 100000] [--requests 100] [--backends sqlite,postgresql]

For each backend: a center database seeded through the storage functions (20 clinics, one case every few minutes
over about a year, one encounter in five re-sent, a third advised), then `burnedge central` on loopback and, one
request at a time, GET /api/v1/cases for the first page, filtered pages and a page 20 cursors deep (each with its
total count). Baseline, same run and database: the list as it was before it was paged (every stored version with
its correlated subqueries, sorted and cut in Python), timed in this process. PostgreSQL is the test harness's
throwaway server (fsync off: this measures reads, not durability). Goal (issue 22): p95 <= 100 ms.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

import httpx

from base.storage.database import Database
from base.storage.postgres import PostgresDatabase
from center.storage.cases import case_item
from harness.case_seed import START, seeded_center
from harness.postgres import PostgresServer
from harness.processes import login

# The list before issue 22's paging: what every request ran, over every row.
_WHOLE_LIST_SQL = """
    SELECT b.*, p.identity AS peer_identity,
        (SELECT n.bundle_id FROM bundles n WHERE n.site_id = b.site_id AND n.encounter_id = b.encounter_id
            AND n.version > b.version ORDER BY n.version DESC LIMIT 1) AS superseded_by_now,
        (SELECT COUNT(*) FROM notes t WHERE t.site_id = b.site_id AND t.encounter_id = b.encounter_id) AS notes,
        (SELECT COUNT(*) FROM notes t WHERE t.site_id = b.site_id AND t.encounter_id = b.encounter_id
            AND t.written_at >= b.stored_at) AS notes_since
    FROM bundles b JOIN peers p ON p.site_id = b.site_id ORDER BY b.urgency_rank, b.stored_at"""


def percentiles(samples: list[float]) -> dict:
    samples = sorted(samples)
    return {
        "p50_ms": round(statistics.median(samples), 1),
        "p95_ms": round(samples[max(0, int(0.95 * len(samples)) - 1)], 1),
    }


def timed_get(client: httpx.Client, path: str, params: dict, n: int) -> dict:
    client.get(path, params=params).raise_for_status()
    samples = []
    for _ in range(n):
        start = time.perf_counter()
        r = client.get(path, params=params)
        r.raise_for_status()
        samples.append((time.perf_counter() - start) * 1000)
    page = r.json()
    total = f"{page['total']}{'+' if page['total_capped'] else ''}"
    return {**percentiles(samples), "total": total, "rows": len(page["cases"])}


def whole_list(database: str, n: int) -> dict:
    """The replaced list: every version read and decoded, superseded ones dropped, awaiting first, first 200."""
    db = PostgresDatabase(database) if database.startswith("postgresql://") else Database(database)
    samples = []
    try:
        for _ in range(n):
            start = time.perf_counter()
            rows = db.connection().execute(_WHOLE_LIST_SQL).fetchall()
            items = [case_item(r) for r in rows if r["superseded_by_now"] is None]
            items.sort(key=lambda i: (not i.awaiting_advice,))
            items = items[:200]
            samples.append((time.perf_counter() - start) * 1000)
    finally:
        db.close()
    return percentiles(samples)


def deep_cursor(client: httpx.Client, pages: int) -> str:
    after = None
    for _ in range(pages):
        after = client.get("/api/v1/cases", params={"after": after} if after else {}).json()["next_after"]
    return after


def measure(work: Path, backend: str, cases: int, n: int, server: PostgresServer | None) -> dict:
    database = server.create_database("bench") if server else None
    start = time.perf_counter()
    center = seeded_center(work / backend, cases, clinics=20, database=database)
    seed_s = time.perf_counter() - start
    center.start(timeout=120)
    try:
        with httpx.Client(base_url=center.url, timeout=60) as client:
            client.headers.update(login(client, "consult"))
            day = (START + dt.timedelta(minutes=5 * cases // 2)).date().isoformat()  # mid-way through the seeding
            workloads = {
                "first page (50)": {},
                "awaiting, immediate": {"state": "awaiting", "urgency": "immediate"},
                "one clinic": {"site_id": "clinic-007"},
                "one day": {"received_from": day, "received_to": day},
                "superseded versions": {"state": "superseded"},
                "200 per page": {"limit": 200},
                "page 21 (cursor)": {"after": deep_cursor(client, 20)},
            }
            rows = {name: timed_get(client, "/api/v1/cases", params, n) for name, params in workloads.items()}
        baseline = whole_list(center.env["BURNEDGE_CENTRAL_DATABASE"], max(3, n // 20))
    finally:
        center.stop()
    return {"seed_s": round(seed_s, 1), "workloads": rows, "whole list (before)": baseline}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cases", type=int, default=100_000, help="case versions seeded per backend")
    parser.add_argument("--requests", type=int, default=100, help="timed requests per workload")
    parser.add_argument("--backends", default="sqlite,postgresql")
    parser.add_argument("--json", help="also write the figures here")
    args = parser.parse_args()
    results = {}
    server = None
    with tempfile.TemporaryDirectory() as tmp:
        try:
            for backend in args.backends.split(","):
                if backend == "postgresql" and server is None:
                    server = PostgresServer().start()
                results[backend] = measure(Path(tmp), backend, args.cases, args.requests, server)
        finally:
            if server is not None:
                server.stop()
    figures = {
        "date": dt.date.today().isoformat(),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores",
        "cases": args.cases,
        "requests": args.requests,
        "results": results,
    }
    for backend, result in results.items():
        before = result["whole list (before)"]
        print(f"\n{backend}: {args.cases} cases seeded in {result['seed_s']} s")
        print(f"  {'workload':24} {'p50 ms':>8} {'p95 ms':>8} {'matching':>9} {'rows':>5}")
        for name, row in result["workloads"].items():
            print(f"  {name:24} {row['p50_ms']:8} {row['p95_ms']:8} {row['total']:9} {row['rows']:5}")
        print(f"  {'whole list (before)':24} {before['p50_ms']:8} {before['p95_ms']:8}")
        worst = max(row["p95_ms"] for row in result["workloads"].values())
        print(f"  worst p95 {worst} ms (goal <= 100); before / worst p95: {before['p95_ms'] / worst:.0f}x")
    if args.json:
        Path(args.json).write_text(json.dumps(figures, indent=2))


if __name__ == "__main__":
    main()
