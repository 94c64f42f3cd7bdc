"""The demo: seed accounts and one realistic burn patient, show the calculated results, serve.

Seeding is idempotent: running the demo again reuses what the database already holds.
"""

from __future__ import annotations

import datetime as dt
import os
import secrets
from pathlib import Path

import msgspec

from gateway.dependencies import Services
from gateway.services.permissions import Principal
from gateway.storage.database import Database
from schemas.accounts import Role, UserCreate
from schemas.base import utcnow
from schemas.burn_chart import BurnChart, BurnChartEntry, BurnDepth
from schemas.burn_chart import LundBrowderRegion as R
from schemas.config import Config
from schemas.patient import Encounter, EncounterMode, Patient, Sex, WeightSource
from schemas.record_parts import (
    Airway,
    Breathing,
    Circulation,
    Disability,
    Exposure,
    FluidGiven,
    Intake,
    Mechanism,
    MechanismType,
    PrimarySurvey,
    Resuscitation,
)  # fmt: skip
from schemas.records import RecordKind

DEMO_PATIENT_ID = "0192f3b4-6a8e-7c3d-9b1a-2f4e5d6c7b8a"
DEMO_ENCOUNTER_ID = "0192f3b4-6a8f-7000-8000-00000000e001"
DEMO_USERS = {"admin": Role.admin, "clinician": Role.clinician, "nurse": Role.nurse, "consultant": Role.consultant}


def seed_accounts(services: Services, credentials_file: Path) -> dict[str, str]:
    """Create the demo accounts once; their random passwords go to a file only its owner can read."""
    conn = services.db.connection()
    if credentials_file.exists() and conn.execute("SELECT 1 FROM users WHERE username = 'clinician'").fetchone():
        return dict(line.split(" ", 1) for line in credentials_file.read_text().split("\n") if line)
    passwords = {name: secrets.token_urlsafe(12) for name in DEMO_USERS}
    for name, role in DEMO_USERS.items():
        services.accounts.create_user(None, UserCreate(username=name, password=passwords[name], role=role,
                                                       display_name=f"Demo {role.value}"))  # fmt: skip
    credentials_file.unlink(missing_ok=True)
    fd = os.open(credentials_file, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write("".join(f"{name} {pw}\n" for name, pw in passwords.items()))
    return passwords


def seed_patient(services: Services) -> None:
    conn = services.db.connection()
    row = conn.execute("SELECT id FROM users WHERE username = 'clinician'").fetchone()
    who = Principal(row["id"], "clinician", Role.clinician, None, "demo-seed")
    if services.records.list_records(who, RecordKind.patient, limit=1):
        return
    now = utcnow().replace(microsecond=0)
    injury = now - dt.timedelta(hours=2)
    enc = DEMO_ENCOUNTER_ID
    records = [
        (RecordKind.patient, DEMO_PATIENT_ID, Patient(
            id=DEMO_PATIENT_ID, given_name="Amina", family_name="Demo", date_of_birth=dt.date(1991, 4, 12),
            sex=Sex.female, weight_kg=62.0, weight_source=WeightSource.measured, height_cm=165.0)),
        (RecordKind.encounter, enc, Encounter(
            id=enc, patient_id=DEMO_PATIENT_ID, mode=EncounterMode.emergency, time_of_injury=injury,
            time_of_arrival=injury + dt.timedelta(minutes=50), clinician="Dr. Demo", facility="Demo field clinic")),
        (RecordKind.intake, enc, Intake(
            encounter_id=enc, history_of_present_illness="Kerosene stove flare while cooking, clothing caught fire;"
            " flames smothered by a neighbour after about 20 s.", no_known_allergies=True)),
        (RecordKind.mechanism, enc, Mechanism(encounter_id=enc, type=MechanismType.flame, duration_s=20,
                                              agent="kerosene stove")),
        (RecordKind.primary_survey, enc, PrimarySurvey(
            encounter_id=enc, assessed_at=injury + dt.timedelta(minutes=55), airway=Airway(patent=True),
            breathing=Breathing(respiratory_rate_per_min=22, spo2_percent=97),
            circulation=Circulation(heart_rate_per_min=112, systolic_bp_mmhg=118, diastolic_bp_mmhg=74, iv_access=True),
            disability=Disability(gcs_eye=4, gcs_verbal=5, gcs_motor=6), exposure=Exposure(temperature_c=36.4,
            burn_cooled=True, cooling_minutes=20))),
        (RecordKind.burn_chart, enc, BurnChart(encounter_id=enc, assessed_at=injury + dt.timedelta(minutes=70), entries=[
            BurnChartEntry(region=R.trunk_anterior, fraction=0.6, depth=BurnDepth.deep_partial),
            BurnChartEntry(region=R.upper_arm_right_anterior, fraction=1.0, depth=BurnDepth.superficial_partial),
            BurnChartEntry(region=R.lower_arm_right_anterior, fraction=1.0, depth=BurnDepth.superficial_partial),
            BurnChartEntry(region=R.thigh_right_anterior, fraction=0.5, depth=BurnDepth.full_thickness),
            BurnChartEntry(region=R.neck_anterior, fraction=1.0, depth=BurnDepth.superficial)])),
        (RecordKind.resuscitation, enc, Resuscitation(encounter_id=enc, fluid_given=[
            FluidGiven(volume_ml=500, given_at=injury + dt.timedelta(minutes=60))])),
    ]  # fmt: skip
    for kind, record_id, struct in records:
        services.records.create(who, kind, record_id, struct)


def demo_config(config: Config) -> Config:
    """The demo keeps its own database unless one was named, and its workers' output in a log beside it (the
    terminal shows the progress bars)."""
    if config.gateway.database == Config().gateway.database:
        config = msgspec.structs.replace(
            config, gateway=msgspec.structs.replace(config.gateway, database="burnedge-demo.sqlite3")
        )
    if not config.jobs.log_file:
        log_file = str(Path(config.gateway.database).resolve().with_suffix(".worker.log"))
        config = msgspec.structs.replace(config, jobs=msgspec.structs.replace(config.jobs, log_file=log_file))
    return config


def seed_demo(config: Config) -> tuple[str, dict[str, str]]:
    """Seed accounts and the demo patient (idempotent); return the summary to show and the accounts' passwords."""
    db_path = Path(config.gateway.database).resolve()
    db = Database.from_config(config.gateway)
    try:
        db.migrate()
        services = Services.build(config, db)
        passwords = seed_accounts(services, db_path.with_suffix(".credentials"))
        seed_patient(services)
        return _summary(services, config, passwords, db_path), passwords
    finally:
        db.close()


def _summary(services: Services, config: Config, passwords: dict[str, str], db_path: Path) -> str:
    who = Principal("demo", "clinician", Role.clinician, None, "demo")
    result = services.records.get(who, RecordKind.assessment, DEMO_ENCOUNTER_ID).data
    tbsa, fluids, referral = result["tbsa"], result["fluids"], result["referral"]
    base = f"http://{config.gateway.host}:{config.gateway.port}"
    lines = [
        "burnedge demo: one patient seeded in " + str(db_path),
        f"  %TBSA (Lund-Browder, superficial excluded): {tbsa['tbsa_percent']:.1f} %"
        f"  (Rule of Nines: {tbsa['rule_of_nines_percent']:.1f} %)",
        f"  Fluids ({fluids['formula']}, {fluids['ml_per_kg_per_percent']} mL/kg/%TBSA): 24 h {fluids['total_24h_ml']:.0f} mL;"
        f" run {fluids['rate_now_ml_per_h']:.0f} mL/h now ({fluids['fluid_given_ml']:.0f} mL already given)",
        f"  Referral ({referral['current']['version']}): {referral['current']['recommendation']}",
        "  " + result["notice"],
        "",
        f"Gateway: {base}  (API docs: {base}/schema)",
        "Accounts (passwords also in " + str(db_path.with_suffix(".credentials")) + "):",
        *[f"  {name:<11} {pw}" for name, pw in passwords.items()],
        f"Try: curl -s -X POST {base}/api/v1/auth/login -H 'content-type: application/json'"
        f' -d \'{{"username":"clinician","password":"{passwords["clinician"]}"}}\'',
    ]
    return "\n".join(lines)
