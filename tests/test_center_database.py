"""The center's storage on both backends: migrations, and commits that race between workers sharing a database.

Two Receivers over the same database and store folder stand for two `burnedge central` workers: each has its own
locks and caches, so nothing but the database keeps them from storing a bundle twice.
"""

from __future__ import annotations

import threading
import uuid
from pathlib import Path

import pytest

from base.folders import center_store_dir
from center.app import CentralServices, open_center_db
from center.receiver import Receiver
from harness.center_bundles import make_bundle
from schemas.config import CentralConfig, Config
from schemas.errors import InvalidInput, TransferRejected
from schemas.transfer import SiteRole
from sync import peers
from sync.keys import init_keys


@pytest.fixture
def center(tmp_path: Path, center_database: str):
    central = CentralConfig(
        database=center_database, store_dir=str(tmp_path / "store"), keys_dir=str(tmp_path / "center-keys")
    )
    db = open_center_db(central)
    keys = init_keys(tmp_path / "center-keys", "center-a", SiteRole.center, "Center")
    clinic = init_keys(tmp_path / "clinic-keys", "clinic-a", SiteRole.clinic, "Clinic")
    peers.enrol(db, clinic.identity, by="it-person")
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
            assert [r[0] for r in applied] == ["c001_center", "c002_audit_anchors", "c003_must_change_password"]
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
