"""The demo: seed accounts and one realistic burn patient, show the calculated results, serve.

Seeding is idempotent: running the demo again reuses what the database already holds.
"""

from __future__ import annotations

import datetime as dt
import os
import secrets
from pathlib import Path

import msgspec

from base.accounts.permissions import Principal
from base.storage import accounts as account_rows
from gateway.dependencies import Services
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
    Intake,
    Mechanism,
    MechanismType,
    PrimarySurvey,
    SecondarySurvey,
)
from schemas.records import RecordKind
from schemas.wound import Wound, WoundSide

DEMO_PATIENT_ID = "0192f3b4-6a8e-7c3d-9b1a-2f4e5d6c7b99"
"""The one demo patient: the healing series (burnedge/demo_series.py) is his forearm burn."""
DEMO_VISIT_IDS = [f"0192f3b4-6a8f-7000-8000-00000000f00{i}" for i in range(4)]
FOREARM_WOUND_ID = "0192f3b4-6a90-7000-8000-00000000a001"
"""The forearm burn the healing series follows over four visits."""
SHIN_WOUND_ID = "0192f3b4-6a90-7000-8000-00000000a002"
"""A second, smaller splash burn on the left shin, photographed on the first visit: tracked apart from the forearm."""
DEMO_ENCOUNTER_ID = DEMO_VISIT_IDS[0]
"""The day-0 emergency visit, with the full record."""
SERIES_DAYS = (0, 7, 14, 21)
BURN_REGION_FRACTION = 0.065
"""The charted share of the right forearm's back (Lund-Browder: 1.5 % of an adult's body surface): about 18 cm2 on
this patient (1.85 m2), the size of the rendered burn."""
SHIN_REGION_FRACTION = 0.01
"""The charted share of the front of the left lower leg (Lund-Browder: 3.5 % of an adult's body surface): about
6 cm2, the size of the second rendered burn."""
SHIN_AREA_CM2 = 6.0
DEMO_USERS = {"admin": Role.admin, "clinician": Role.clinician, "nurse": Role.nurse, "consultant": Role.consultant}


def seed_accounts(services: Services, credentials_file: Path) -> dict[str, str]:
    """Create the demo accounts once; their random passwords go to a file only its owner can read."""
    conn = services.db.connection()
    if credentials_file.exists() and account_rows.find_user_named(conn, "clinician") is not None:
        return dict(line.split(" ", 1) for line in credentials_file.read_text().split("\n") if line)
    passwords = {name: secrets.token_urlsafe(12) for name in DEMO_USERS}
    for name, role in DEMO_USERS.items():
        services.accounts.create_user(
            None, UserCreate(username=name, password=passwords[name], role=role, display_name=f"Demo {role.value}")
        )
    credentials_file.unlink(missing_ok=True)
    fd = os.open(credentials_file, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "w") as f:
        f.write("".join(f"{name} {pw}\n" for name, pw in passwords.items()))
    return passwords


def seed_patient(services: Services) -> None:
    """The demo patient: a small deep partial-thickness burn of the right forearm from a pan of hot oil, seen on
    the day and at 7, 14 and 21 days (the visits the series' photos belong to), and a smaller splash of the same
    oil on the left shin: two wounds, each tracked on its own."""
    clinician = services.accounts.user_named("clinician")
    who = Principal(clinician.id, "clinician", Role.clinician, None, "demo-seed")
    if services.records.list_records(who, RecordKind.patient, limit=1):
        return
    first = utcnow().replace(microsecond=0) - dt.timedelta(days=SERIES_DAYS[-1], hours=1)
    injury = first - dt.timedelta(hours=3)
    enc = DEMO_ENCOUNTER_ID
    records = [
        (
            RecordKind.patient,
            DEMO_PATIENT_ID,
            Patient(
                id=DEMO_PATIENT_ID,
                given_name="Tomas",
                family_name="Demo",
                date_of_birth=dt.date(1984, 9, 2),
                sex=Sex.male,
                weight_kg=71.0,
                weight_source=WeightSource.measured,
                height_cm=174.0,
            ),
        ),
        *[
            (
                RecordKind.encounter,
                visit,
                Encounter(
                    id=visit,
                    patient_id=DEMO_PATIENT_ID,
                    mode=EncounterMode.emergency if day == 0 else EncounterMode.consultation,
                    time_of_injury=injury,
                    time_of_arrival=first + dt.timedelta(days=day),
                    clinician="Dr. Demo",
                    facility="Demo field clinic",
                ),
            )
            for day, visit in zip(SERIES_DAYS, DEMO_VISIT_IDS, strict=True)
        ],
        (
            RecordKind.intake,
            enc,
            Intake(
                encounter_id=enc,
                history_of_present_illness="A pan of hot cooking oil tipped over the back of the right"
                " forearm while cooking; cooled under running water for 20 minutes at home.",
                no_known_allergies=True,
            ),
        ),
        (
            RecordKind.mechanism,
            enc,
            Mechanism(encounter_id=enc, type=MechanismType.scald, duration_s=5, agent="hot cooking oil"),
        ),
        (
            RecordKind.primary_survey,
            enc,
            PrimarySurvey(
                encounter_id=enc,
                assessed_at=first + dt.timedelta(minutes=5),
                airway=Airway(patent=True),
                breathing=Breathing(respiratory_rate_per_min=16, spo2_percent=99),
                circulation=Circulation(heart_rate_per_min=88, systolic_bp_mmhg=128, diastolic_bp_mmhg=80),
                disability=Disability(gcs_eye=4, gcs_verbal=5, gcs_motor=6),
                exposure=Exposure(temperature_c=36.8, burn_cooled=True, cooling_minutes=20, jewellery_removed=True),
                pain_poorly_controlled=False,
            ),
        ),
        (
            RecordKind.secondary_survey,
            enc,
            SecondarySurvey(
                encounter_id=enc,
                assessed_at=first + dt.timedelta(minutes=10),
                notes="No other injury; no blistering elsewhere.",
            ),
        ),
        (
            RecordKind.burn_chart,
            enc,
            BurnChart(
                encounter_id=enc,
                assessed_at=first + dt.timedelta(minutes=15),
                entries=[
                    BurnChartEntry(
                        region=R.lower_arm_right_posterior, fraction=BURN_REGION_FRACTION, depth=BurnDepth.deep_partial
                    ),
                    BurnChartEntry(
                        region=R.lower_leg_left_anterior,
                        fraction=SHIN_REGION_FRACTION,
                        depth=BurnDepth.superficial_partial,
                    ),
                ],
            ),
        ),
        (
            RecordKind.wound,
            FOREARM_WOUND_ID,
            Wound(
                id=FOREARM_WOUND_ID,
                patient_id=DEMO_PATIENT_ID,
                regions=[R.lower_arm_right_posterior],
                label="right forearm",
                side=WoundSide.right,
                site_detail="back of the forearm, mid-shaft",
                cause=MechanismType.scald,
                time_of_injury=injury,
            ),
        ),
        (
            RecordKind.wound,
            SHIN_WOUND_ID,
            Wound(
                id=SHIN_WOUND_ID,
                patient_id=DEMO_PATIENT_ID,
                regions=[R.lower_leg_left_anterior],
                label="left shin",
                side=WoundSide.left,
                site_detail="splash, front of the shin",
                cause=MechanismType.scald,
                time_of_injury=injury,
            ),
        ),
    ]
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


def _fluid_line(fluids: dict) -> str:
    if not fluids["formal_resuscitation_indicated"]:
        target = fluids["urine_output_target"]
        return (
            f"formal resuscitation not indicated ({fluids['tbsa_percent']:g} %TBSA, below "
            f"{fluids['formal_resuscitation_threshold_percent']:g} %): oral or maintenance fluids; urine output "
            f"{target['ml_per_h_low']:.0f}-{target['ml_per_h_high']:.0f} mL/h"
        )
    return (
        f"{fluids['formula']}, {fluids['ml_per_kg_per_percent']} mL/kg/%TBSA: 24 h {fluids['total_24h_ml']:.0f} mL;"
        f" run {fluids['rate_now_ml_per_h']:.0f} mL/h now ({fluids['fluid_given_ml']:.0f} mL already given)"
    )


def _summary(services: Services, config: Config, passwords: dict[str, str], db_path: Path) -> str:
    who = Principal("demo", "clinician", Role.clinician, None, "demo")
    result = services.records.get(who, RecordKind.assessment, DEMO_ENCOUNTER_ID).data
    tbsa, fluids, referral = result["tbsa"], result["fluids"], result["referral"]
    base = f"http://{config.gateway.host}:{config.gateway.port}"
    lines = [
        "burnedge demo: one patient seeded in " + str(db_path) + ": Tomas Demo, a deep partial-thickness burn of the"
        " right forearm (hot oil), seen on the day and at 7, 14 and 21 days, and a smaller splash on the left shin"
        " (two wounds, tracked apart)",
        f"  %TBSA (Lund-Browder, superficial excluded): {tbsa['tbsa_percent']:.1f} %"
        f"  (Rule of Nines: {tbsa['rule_of_nines_percent']:.1f} %)",
        "  Fluids: " + _fluid_line(fluids),
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
