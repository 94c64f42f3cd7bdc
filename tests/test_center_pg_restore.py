"""The restore drill of deploy/postgresql.md, run for real: a center on PostgreSQL backed up with `pg_dump`, restored
with `pg_restore` into a new database, and opened there by the center as it stands, every case, note and audit
entry intact."""

from __future__ import annotations

import sqlite3
import subprocess
import uuid
from pathlib import Path

import msgspec
import pytest

from base.accounts.service import AccountService
from base.storage import audit
from center.app import open_center_db
from center.cases import CaseService
from center.receiver import Receiver
from center.storage import notes
from harness.case_seed import enrol_clinics, seed_cases
from harness.postgres import server_binaries
from schemas.accounts import Role, UserCreate
from schemas.base import iso, utcnow
from schemas.central import CaseFilter, CaseState
from schemas.config import CentralConfig
from schemas.transfer import ConsultationNote, MailRequest, Recommendation, SiteRole
from sync import peers
from sync.keys import init_keys
from sync.mailbox import open_note, seal_note
from tests.conftest import CONSULTANT, FAST_SECURITY


def tool(name: str, *args: str) -> None:
    result = subprocess.run([str(server_binaries() / name), *args], capture_output=True, text=True, timeout=120)
    if result.returncode != 0:
        raise AssertionError(f"{name} failed ({result.returncode}): {result.stderr}")


def snapshot(db, keys, tmp_path: Path) -> dict:
    service = CaseService(db, keys, tmp_path / "store")
    rows = db.connection().execute("SELECT COUNT(*) FROM bundles").fetchone()[0]
    notes = db.connection().execute("SELECT COUNT(*) FROM notes").fetchone()[0]
    pages = {state: service.list_cases(CONSULTANT, CaseFilter(state=state, limit=200)) for state in CaseState}
    with db.read() as conn:
        verification = audit.verify(conn, None, served_records=False)
    return {"bundles": rows, "notes": notes, "pages": pages, "audit": (verification.ok, verification.entries)}


def test_a_center_dumped_with_pg_dump_and_restored_with_pg_restore_serves_every_case(postgres_server, tmp_path):
    source = postgres_server.create_database("live")
    central = CentralConfig(database=source, store_dir=str(tmp_path / "store"), keys_dir=str(tmp_path / "keys"))
    db = open_center_db(central)
    try:
        keys = init_keys(tmp_path / "keys", "center-a", SiteRole.center, "Center")
        seed_cases(db, keys, enrol_clinics(db, tmp_path / "clinics", 2), 150)
        AccountService(db, FAST_SECURITY).create_user(
            None, UserCreate(username="consult", password="a long passphrase", role=Role.consultant)
        )
        before = snapshot(db, keys, tmp_path)
    finally:
        db.close()
    assert before["bundles"] == 150 and before["audit"][0] and before["audit"][1] >= 1

    dump = tmp_path / "central.dump"
    tool("pg_dump", "--format=custom", f"--file={dump}", source)
    restored = postgres_server.create_database("restored")
    tool("pg_restore", "--no-owner", "--exit-on-error", f"--dbname={restored}", str(dump))

    again = open_center_db(CentralConfig(database=restored, store_dir=central.store_dir, keys_dir=central.keys_dir))
    try:
        assert again.migrate("burnedge-central", []) == []
        after = snapshot(again, keys, tmp_path)
    finally:
        again.close()
    assert after == before


def test_pg_restore_into_a_database_that_holds_a_center_already_stops_at_the_first_conflict(postgres_server, tmp_path):
    source = postgres_server.create_database("live")
    db = open_center_db(CentralConfig(database=source, store_dir=str(tmp_path / "s"), keys_dir=str(tmp_path / "k")))
    db.close()
    dump = tmp_path / "central.dump"
    tool("pg_dump", "--format=custom", f"--file={dump}", source)
    with pytest.raises(AssertionError, match="already exists"):
        tool("pg_restore", "--no-owner", "--exit-on-error", f"--dbname={source}", str(dump))


class Mail:
    """A clinic's side of the mailbox against one center database: it keeps every note once, by id, and asks
    after the highest number it has read, as sync/mailbox.py does."""

    def __init__(self, clinic, center_keys):
        self.clinic, self.center_keys = clinic, center_keys
        self.read, self.notes = 0, {}

    def poll(self, db, tmp_path: Path) -> list[str]:
        receiver = Receiver(db, CentralConfig(database="unused"), self.center_keys, tmp_path / "store")
        ask = MailRequest(site_id="clinic-a", center_id="center-a", after=self.read, sent_at=iso(utcnow()))
        envelopes = receiver.mail("clinic-a", msgspec.msgpack.encode(self.clinic.sign("mail-request", ask)))
        new = []
        for envelope in envelopes:
            seq, note = open_note(envelope, self.center_keys.identity, self.clinic)
            self.read = max(self.read, seq)
            if note.note_id not in self.notes:
                self.notes[note.note_id] = note
                new.append(note.advice)
        return new


ENCOUNTER = str(uuid.uuid4())


def advising_center(central: CentralConfig, tmp_path: Path):
    """An open center database with its keys, the clinic `clinic-a` enrolled, and that clinic's mailbox."""
    db = open_center_db(central)
    center_keys = init_keys(Path(central.keys_dir), "center-a", SiteRole.center, "Center")
    clinic = init_keys(tmp_path / "clinic", "clinic-a", SiteRole.clinic, "Clinic")
    peers.enrol(db, clinic.identity, by="it")
    return db, center_keys, clinic, Mail(clinic, center_keys)


def advise(db, center_keys, clinic, text: str) -> None:
    note = ConsultationNote(
        note_id=str(uuid.uuid4()),
        encounter_id=ENCOUNTER,
        patient_id=ENCOUNTER,
        bundle_id=ENCOUNTER,
        bundle_version=1,
        center_id="center-a",
        consultant="Dr Consultant",
        consultant_user_id="u1",
        written_at=iso(utcnow()),
        recommendation=Recommendation.manage_locally,
        advice=text,
    )
    with db.write() as conn:
        seq = notes.insert_note(conn, "clinic-a", note)
        notes.attach_sealed(conn, seq, seal_note(center_keys, clinic.identity, seq, note))


def test_advice_written_after_a_restore_reaches_the_clinic_that_had_read_past_the_backup(postgres_server, tmp_path):
    source = postgres_server.create_database("live")
    db, center_keys, clinic, mail = advising_center(
        CentralConfig(database=source, store_dir=str(tmp_path / "s"), keys_dir=str(tmp_path / "k")), tmp_path
    )
    try:
        advise(db, center_keys, clinic, "first")
        tool("pg_dump", "--format=custom", f"--file={tmp_path / 'nightly.dump'}", source)
        advise(db, center_keys, clinic, "second, after the backup")
        advise(db, center_keys, clinic, "third, after the backup")
        assert mail.poll(db, tmp_path) == ["first", "second, after the backup", "third, after the backup"]
    finally:
        db.close()  # the database is lost; the clinic has read notes 1 to 3

    restored = postgres_server.create_database("restored")
    tool("pg_restore", "--no-owner", "--exit-on-error", f"--dbname={restored}", str(tmp_path / "nightly.dump"))
    db = open_center_db(CentralConfig(database=restored, store_dir=str(tmp_path / "s"), keys_dir=str(tmp_path / "k")))
    try:
        advise(db, center_keys, clinic, "fourth, after the restore")  # a counter would number it 2 again
        assert mail.poll(db, tmp_path) == ["fourth, after the restore"]
        advise(db, center_keys, clinic, "fifth")
        assert mail.poll(db, tmp_path) == ["fifth"]
    finally:
        db.close()


def test_a_sqlite_center_restored_from_a_copy_also_numbers_new_advice_past_what_the_clinic_read(tmp_path):
    live, copy = tmp_path / "center.sqlite3", tmp_path / "nightly.sqlite3"
    central = CentralConfig(database=str(live), store_dir=str(tmp_path / "s"), keys_dir=str(tmp_path / "k"))
    db, center_keys, clinic, mail = advising_center(central, tmp_path)
    try:
        advise(db, center_keys, clinic, "first")
        with sqlite3.connect(live) as source, sqlite3.connect(copy) as target:
            source.backup(target)
        advise(db, center_keys, clinic, "second, after the backup")
        assert mail.poll(db, tmp_path) == ["first", "second, after the backup"]
    finally:
        db.close()
    for leftover in (tmp_path / "center.sqlite3-wal", tmp_path / "center.sqlite3-shm"):
        leftover.unlink(missing_ok=True)  # a restore puts back the database, not the lost one's journal
    copy.replace(live)
    db = open_center_db(central)
    try:
        advise(db, center_keys, clinic, "third, after the restore")
        assert mail.poll(db, tmp_path) == ["third, after the restore"]
    finally:
        db.close()
