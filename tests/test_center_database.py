"""The center's storage on both backends: migrations, and commits that race between workers sharing a database.

Two Receivers over the same database and store folder stand for two `burnedge central` workers: each has its own
locks and caches, so nothing but the database keeps them from storing a bundle twice.
"""

from __future__ import annotations

import datetime as dt
import threading
import uuid
from pathlib import Path

import msgspec
import pytest

from base.folders import center_store_dir
from center.app import CentralServices, open_center_db
from center.cases import CaseService
from center.receiver import Receiver
from harness.case_seed import enrol_clinics, seed_cases
from harness.center_bundles import make_bundle
from schemas.central import CaseFilter, CaseState
from schemas.config import CentralConfig, Config
from schemas.errors import InvalidInput, TransferRejected
from schemas.transfer import URGENCY_ORDER, SiteRole, Urgency
from sync import peers
from sync.keys import init_keys
from tests.conftest import CONSULTANT


def enrolled_center(tmp_path: Path, center_database: str):
    """A center's config, open database and keys, with the clinic `clinic-a` enrolled (and its keys)."""
    central = CentralConfig(
        database=center_database, store_dir=str(tmp_path / "store"), keys_dir=str(tmp_path / "center-keys")
    )
    db = open_center_db(central)
    keys = init_keys(tmp_path / "center-keys", "center-a", SiteRole.center, "Center")
    clinic = init_keys(tmp_path / "clinic-keys", "clinic-a", SiteRole.clinic, "Clinic")
    peers.enrol(db, clinic.identity, by="it-person")
    return central, db, keys, clinic


@pytest.fixture
def center(tmp_path: Path, center_database: str):
    central, db, keys, clinic = enrolled_center(tmp_path, center_database)
    yield central, db, keys, clinic
    db.close()


def workers(central: CentralConfig, db, keys, count: int = 2) -> list[Receiver]:
    return [Receiver(db, central, keys, center_store_dir(central)) for _ in range(count)]


def at_once(calls) -> list:
    """Run the calls in threads released together; their results (or exceptions) in order."""
    barrier = threading.Barrier(len(calls))
    results: list = [None] * len(calls)

    def run(i, call):
        barrier.wait()
        try:
            results[i] = call()
        except Exception as exc:  # collected for the test to look at
            results[i] = exc

    threads = [threading.Thread(target=run, args=(i, c)) for i, c in enumerate(calls)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(60)
    return results


def send_chunks(receiver: Receiver, clinic, bundle_id: str, sealed) -> None:
    for i, (ref, data) in enumerate(zip(sealed.refs, sealed.chunks, strict=True)):
        receiver.chunk(clinic.site_id, bundle_id, i, ref.sha256, data)


def test_migrations_apply_once_and_a_second_open_finds_nothing_to_do(center, center_database: str):
    central, _, _, _ = center
    again = open_center_db(central)
    try:
        rows = again.connection().execute("SELECT site_id, role FROM peers").fetchall()
        assert [(r["site_id"], r["role"]) for r in rows] == [("clinic-a", "clinic")]
        if center_database.startswith("postgresql://"):
            assert again.migrate("burnedge-central", []) == []
            applied = again.connection().execute("SELECT name FROM burnedge_migrations ORDER BY name").fetchall()
            assert [r[0] for r in applied] == [
                "c001_center",
                "c002_audit_anchors",
                "c003_must_change_password",
                "c004_case_queue",
                "c005_sealed_at_rest",
                "c006_refused_bundles",
                "c007_pacs_sends",
            ]
    finally:
        again.close()


def test_two_workers_committing_one_bundle_at_the_same_instant_store_it_once(center):
    central, db, keys, clinic = center
    first, second = workers(central, db, keys)
    bundle_id, envelope, sealed = make_bundle(clinic, keys.identity, str(uuid.uuid4()), 1)
    assert first.announce(clinic.site_id, envelope).status == "send"
    send_chunks(second, clinic, bundle_id, sealed)  # the chunks may reach any worker

    replies = at_once(
        [lambda: first.commit(clinic.site_id, bundle_id), lambda: second.commit(clinic.site_id, bundle_id)]
    )
    assert [r.status for r in replies] == ["stored", "stored"], replies
    assert replies[0].receipt == replies[1].receipt  # the loser answers with the winner's receipt
    conn = db.connection()
    assert conn.execute("SELECT COUNT(*) FROM bundles").fetchone()[0] == 1
    assert conn.execute("SELECT COUNT(*) FROM incoming").fetchone()[0] == 0
    assert conn.execute("SELECT COUNT(*) FROM audit_log WHERE action = 'bundle.store'").fetchone()[0] == 1
    # A chunk still on its way to the other worker is taken as a no-op, and a re-send answered with the receipt.
    second.chunk(clinic.site_id, bundle_id, 0, sealed.refs[0].sha256, sealed.chunks[0])
    assert second.announce(clinic.site_id, envelope).receipt == replies[0].receipt
    assert not (center_store_dir(central) / "incoming" / clinic.site_id / bundle_id).exists()

    services = CentralServices.build(Config(central=central), db)
    verified = services.verify_audit(None)
    assert verified.ok, verified.reason


def test_two_bundles_claiming_one_version_at_the_same_instant_store_one_and_refuse_the_other(center):
    central, db, keys, clinic = center
    first, second = workers(central, db, keys)
    encounter = str(uuid.uuid4())
    made = [make_bundle(clinic, keys.identity, encounter, 1) for _ in range(2)]
    for worker, (bundle_id, envelope, sealed) in zip((first, second), made, strict=True):
        assert worker.announce(clinic.site_id, envelope).status == "send"
        send_chunks(worker, clinic, bundle_id, sealed)

    replies = at_once(
        [lambda w=w, b=m[0]: w.commit(clinic.site_id, b) for w, m in zip((first, second), made, strict=True)]
    )
    stored = [r for r in replies if not isinstance(r, Exception)]
    refused = [r for r in replies if isinstance(r, TransferRejected)]
    assert len(stored) == 1 and stored[0].status == "stored", replies
    assert len(refused) == 1 and refused[0].code == "replayed", replies
    versions = db.connection().execute("SELECT encounter_id, version FROM bundles").fetchall()
    assert [tuple(r) for r in versions] == [(encounter, 1)]
    assert db.connection().execute("SELECT COUNT(*) FROM incoming").fetchone()[0] == 0


def test_a_postgres_center_names_its_folders_or_says_which_setting_is_missing(tmp_path: Path):
    central = CentralConfig(database="postgresql://burnedge@127.0.0.1:1/none")
    with pytest.raises(InvalidInput, match=r"\[central\] store_dir must be set"):
        center_store_dir(central)


def reference_order(conn) -> list[tuple]:
    """Every stored version worked out from the raw rows, not the maintained columns: (site, bundle, urgency rank,
    stored_at, superseded, awaiting)."""
    bundles = conn.execute("SELECT site_id, bundle_id, encounter_id, version, urgency_rank, stored_at FROM bundles")
    bundles = bundles.fetchall()
    written = conn.execute("SELECT site_id, encounter_id, written_at FROM notes").fetchall()
    newest: dict[tuple, int] = {}
    for b in bundles:
        key = (b["site_id"], b["encounter_id"])
        newest[key] = max(newest.get(key, 0), b["version"])
    rows = []
    for b in bundles:
        key = (b["site_id"], b["encounter_id"])
        advised = any((n["site_id"], n["encounter_id"]) == key and n["written_at"] >= b["stored_at"] for n in written)
        rows.append(
            (b["site_id"], b["bundle_id"], b["urgency_rank"], b["stored_at"], b["version"] < newest[key], not advised)
        )
    return sorted(rows, key=lambda r: (r[4], not r[5], r[2], r[3], r[0], r[1]))


def every_page(service: CaseService, wanted: CaseFilter) -> tuple[list, set[int]]:
    seen, totals, after = [], set(), wanted.after
    while True:
        page = service.list_cases(CONSULTANT, msgspec.structs.replace(wanted, after=after))
        seen.extend(page.cases)
        totals.add(page.total)
        if page.next_after is None:
            return seen, totals
        assert len(page.cases) == wanted.limit
        after = page.next_after


@pytest.fixture
def seeded(center, tmp_path: Path):
    central, db, keys, _ = center
    site_ids = enrol_clinics(db, tmp_path / "seed-keys", 3)
    seed_cases(db, keys, site_ids, 320, batch=80)
    return CaseService(db, keys, tmp_path / "store"), db, site_ids


def test_the_case_list_pages_through_every_filter_in_order_with_nothing_missed_or_repeated(seeded):
    service, db, site_ids = seeded
    everything = reference_order(db.connection())
    assert 40 < sum(r[4] for r in everything) < 120 and 60 < sum(not r[5] for r in everything) < 200  # a real mix

    def expect(keep) -> list[tuple[str, str]]:
        return [(r[0], r[1]) for r in everything if keep(r)]

    day_one, day_two = dt.date(2026, 1, 1), dt.date(2026, 1, 2)  # 320 cases a few minutes apart: over a day
    immediate, clinic = URGENCY_ORDER[Urgency.immediate], site_ids[1]
    cases = [
        (CaseFilter(limit=37), lambda r: not r[4]),
        (CaseFilter(limit=50, include_superseded=True), lambda r: True),
        (CaseFilter(limit=20, state=CaseState.awaiting), lambda r: not r[4] and r[5]),
        (CaseFilter(limit=20, state=CaseState.advised), lambda r: not r[4] and not r[5]),
        (CaseFilter(limit=9, state=CaseState.superseded), lambda r: r[4]),
        (
            CaseFilter(limit=7, urgency=Urgency.immediate, site_id=clinic),
            lambda r: not r[4] and r[2] == immediate and r[0] == clinic,
        ),
        (CaseFilter(limit=30, received_to=day_one), lambda r: not r[4] and r[3][:10] == "2026-01-01"),
        (
            CaseFilter(limit=11, received_from=day_two, received_to=day_two),
            lambda r: not r[4] and r[3][:10] == "2026-01-02",
        ),
    ]
    for wanted, keep in cases:
        expected = expect(keep)
        seen, totals = every_page(service, wanted)
        assert expected, wanted
        assert [(c.site_id, c.bundle_id) for c in seen] == expected, wanted
        assert totals == {len(expected)}, wanted


def test_a_case_arriving_between_pages_neither_repeats_nor_hides_the_rest(seeded, center):
    service, db, site_ids = seeded
    _, _, keys, _ = center
    old = {(r[0], r[1]) for r in reference_order(db.connection()) if not r[4]}
    first = service.list_cases(CONSULTANT, CaseFilter(limit=25))
    seed_cases(db, keys, site_ids, 5, seed=99)  # new encounters, awaiting, landing ahead of the cursor and after it
    rest, _ = every_page(service, CaseFilter(limit=25, after=first.next_after))
    seen = [(c.site_id, c.bundle_id) for c in first.cases + rest]
    assert len(seen) == len(set(seen))
    assert old <= set(seen)


def test_a_cursor_the_list_did_not_hand_out_is_refused_in_words(seeded):
    service, _, _ = seeded
    for after in ("not-a-cursor", "AAAA", "kgE"):
        with pytest.raises(InvalidInput, match="next_after"):
            service.list_cases(CONSULTANT, CaseFilter(after=after))


def test_a_count_past_its_limit_says_so_and_the_pages_still_hold_every_case(seeded, monkeypatch):
    service, db, _ = seeded
    latest = [(r[0], r[1]) for r in reference_order(db.connection()) if not r[4]]
    monkeypatch.setattr("center.cases.COUNT_UP_TO", 100)
    first = service.list_cases(CONSULTANT, CaseFilter(limit=30))
    assert (first.total, first.total_capped) == (100, True) and len(latest) > 100
    seen, _ = every_page(service, CaseFilter(limit=30))
    assert [(c.site_id, c.bundle_id) for c in seen] == latest
    few = service.list_cases(CONSULTANT, CaseFilter(state=CaseState.superseded, urgency=Urgency.immediate))
    assert few.total < 100 and not few.total_capped
