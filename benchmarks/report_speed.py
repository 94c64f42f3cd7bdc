"""How long the 4-visit clinical report takes to make, next to reading the same stored records as JSON.

    .venv/bin/python -m benchmarks.report_speed [--db DEMO.sqlite3] [--runs 3]

Without --db, the demo runs first (`burnedge demo --exit` in a temporary folder, a few minutes) to make the
four-visit series. Each run removes the cached reports so the report is made, not served from the cache; the
baseline reads every record the report reads (the encounter's record, the patient's analyses, decision support,
the healing track) and encodes them as JSON, in the same process.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import msgspec

from base.folders import reports_root
from base.storage import records as store
from burnedge.demo import DEMO_ENCOUNTER_ID, DEMO_PATIENT_ID
from gateway.dependencies import Services
from gateway.jobs import timeline
from gateway.storage.database import Database
from harness.processes import REPO
from schemas.config import Config
from schemas.records import RecordKind

GOAL_S = 3.0


def _demo(folder: Path) -> Path:
    db = folder / "burnedge-demo.sqlite3"
    args = [sys.executable, "-m", "burnedge.cli", "--db", str(db), "demo", "--exit", "--port", "18931"]
    subprocess.run(args, cwd=REPO, check=True, stdout=subprocess.DEVNULL)
    return db


def _read_as_json(services: Services, config: Config) -> int:
    conn = services.db.connection()
    record = services.records.encounter_record(_reader(), DEMO_ENCOUNTER_ID)
    parts = [msgspec.json.encode(record)]
    for encounter in store.list_heads(conn, RecordKind.encounter, parent_id=DEMO_PATIENT_ID, limit=None):
        for analysis in store.list_heads(conn, RecordKind.burn_analysis, parent_id=encounter.meta.id, limit=None):
            parts.append(msgspec.json.encode(analysis))
    parts.append(msgspec.json.encode(timeline.read_track(config, DEMO_PATIENT_ID)))
    return sum(len(p) for p in parts)


def _reader():
    from base.accounts.permissions import Principal
    from schemas.accounts import Role

    return Principal("bench", "bench", Role.clinician, None, "bench")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", help="a demo database with the four-visit series (default: run the demo first)")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        db_path = Path(args.db) if args.db else _demo(Path(scratch))
        copy = Path(scratch) / "copy"
        shutil.copytree(db_path.parent, copy, ignore=shutil.ignore_patterns("*.pdf", "burnedge-reports"))
        config = Config()
        config = msgspec.structs.replace(
            config, gateway=msgspec.structs.replace(config.gateway, database=str(copy / db_path.name))
        )
        db = Database.from_config(config.gateway)
        services = Services.build(config, db)
        report_s, read_s, pages, size = [], [], 0, 0
        for _ in range(args.runs):
            shutil.rmtree(reports_root(config), ignore_errors=True)
            start = time.perf_counter()
            made = services.reports.make(None, DEMO_ENCOUNTER_ID)
            report_s.append(time.perf_counter() - start)
            size = len(made.pdf)
            pages = made.pdf.count(b"/Type /Page\n") or made.pdf.count(b"/Type /Page")
            start = time.perf_counter()
            read_bytes = _read_as_json(services, config)
            read_s.append(time.perf_counter() - start)
        start = time.perf_counter()
        services.reports.make(None, DEMO_ENCOUNTER_ID)
        cached_s = time.perf_counter() - start
        db.close()
    report, read = statistics.median(report_s), statistics.median(read_s)
    print(f"4-visit report: median {report:.2f} s over {args.runs} runs ({', '.join(f'{t:.2f}' for t in report_s)}),")
    print(f"  {pages} pages, {size / 1e6:.1f} MB; goal <= {GOAL_S:g} s: {'met' if report <= GOAL_S else 'NOT met'}")
    print(f"baseline, the same records read as JSON: median {read * 1000:.1f} ms ({read_bytes / 1e3:.0f} kB)")
    print(f"report / baseline: {report / read:.0f}x; the cached report served again: {cached_s * 1000:.1f} ms")


if __name__ == "__main__":
    main()
