"""A center's database filled with many cases straight through its storage functions, as years of clinics' bundles
would leave it: for the paging tests and the case-list benchmark (no sealing, no transfer)."""

from __future__ import annotations

import datetime as dt
import random
import uuid
from pathlib import Path

import msgspec

from base.folders import center_keys_dir
from base.storage.postgres import AnyDatabase
from center.app import open_center_db
from center.storage import cases, notes
from harness.center_bundles import SUMMARY
from harness.processes import PASSWORD, free_port
from harness.sites import CENTER, CenterProcess, cli
from schemas.base import iso
from schemas.config import CentralConfig
from schemas.transfer import BundleManifest, ConsultationNote, Receipt, Recommendation, SiteRole, Urgency
from sync import peers
from sync.keys import SiteKeys, init_keys, load_keys

START = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)


def seeded_center(folder: Path, count: int, *, clinics: int = 3, database: str | None = None) -> CenterProcess:
    """`burnedge central` (not started) over a database holding `count` cases from `clinics` clinics named
    "Clinic 0", "Clinic 1"…, with the consultant `consult` (password PASSWORD)."""
    center = CenterProcess(folder, free_port(), free_port(), database)
    cli("keys", "init", "--center", "--site-id", CENTER, "--name", "Test burn center", env=center.env)
    cli(
        *("users", "add", "--center", "--username", "consult", "--role", "consultant", "--password-stdin"),
        env=center.env,
        stdin=PASSWORD + "\n",
    )
    central = CentralConfig(
        database=center.env["BURNEDGE_CENTRAL_DATABASE"],
        store_dir=center.env["BURNEDGE_CENTRAL_STORE_DIR"],
        keys_dir=center.env["BURNEDGE_CENTRAL_KEYS_DIR"],
    )
    db = open_center_db(central)
    try:
        site_ids = enrol_clinics(db, folder / "clinic-keys", clinics)
        seed_cases(db, load_keys(center_keys_dir(central)), site_ids, count)
    finally:
        db.close()
    return center


def enrol_clinics(db: AnyDatabase, keys_dir: Path, count: int) -> list[str]:
    """Enrol `count` clinics (keys made under keys_dir); their site ids."""
    site_ids = []
    for i in range(count):
        clinic = init_keys(keys_dir / f"clinic-{i}", f"clinic-{i:03d}", SiteRole.clinic, f"Clinic {i}")
        peers.enrol(db, clinic.identity, by="seed")
        site_ids.append(clinic.site_id)
    return site_ids


def seed_cases(
    db: AnyDatabase, center: SiteKeys, site_ids: list[str], count: int, *, seed: int = 7, batch: int = 500
) -> None:
    """Store `count` bundle versions from the clinics, one every few minutes from START: about one encounter in
    five sent a second version, and about a third were advised on, each with its note and the flags it sets."""
    rng = random.Random(seed)
    receipt = center.sign(
        "receipt",
        Receipt(
            center_id=center.site_id,
            site_id="seed",
            bundle_id="seed",
            version=1,
            manifest_sha256="0" * 64,
            stored_at=iso(START),
            duplicate=False,
        ),
    )
    urgencies = list(Urgency)
    at = START
    encounters: list[tuple[str, str, int]] = []
    written = 0
    while written < count:
        with db.write() as conn:
            for _ in range(min(batch, count - written)):
                at += dt.timedelta(minutes=rng.randint(1, 9))
                if encounters and rng.random() < 0.2:
                    site_id, encounter_id, version = encounters.pop(rng.randrange(len(encounters)))
                    version += 1
                else:
                    site_id, encounter_id, version = rng.choice(site_ids), str(uuid.uuid4()), 1
                manifest = _manifest(site_id, encounter_id, version, rng.choice(urgencies), at)
                cases.insert_bundle(
                    conn, site_id, manifest, manifest_sha256="0" * 64, stored_at=iso(at), receipt=receipt
                )
                encounters.append((site_id, encounter_id, version))
                if rng.random() < 0.33:
                    notes.insert_note(conn, site_id, _note(manifest, at + dt.timedelta(minutes=rng.randint(0, 3))))
                written += 1


def _manifest(site_id: str, encounter_id: str, version: int, urgency: Urgency, at: dt.datetime) -> BundleManifest:
    return BundleManifest(
        bundle_id=str(uuid.uuid4()),
        site_id=site_id,
        patient_id=str(uuid.uuid4()),
        encounter_id=encounter_id,
        version=version,
        supersedes=None,
        created_at=iso(at),
        created_by="seed",
        summary=msgspec.structs.replace(SUMMARY, urgency=urgency),
        parts=[],
    )


def _note(manifest: BundleManifest, at: dt.datetime) -> ConsultationNote:
    return ConsultationNote(
        note_id=str(uuid.uuid4()),
        encounter_id=manifest.encounter_id,
        patient_id=manifest.patient_id,
        bundle_id=manifest.bundle_id,
        bundle_version=manifest.version,
        center_id="center-a",
        consultant="Dr. Seed",
        consultant_user_id="seed",
        written_at=iso(at),
        recommendation=Recommendation.manage_locally,
        advice="Seeded advice.",
    )
