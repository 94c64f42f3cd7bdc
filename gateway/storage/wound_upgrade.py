"""The upgrade to wounds (migration m010): one wound per patient that has analyses, holding all of them.

The wound's regions are those the patient's burn charts record (none when there is no chart: the clinician sets
them); its time of injury is the latest encounter's. It is written as the gateway's own record, so phones get it in
their change feed and the audit chain records it.
"""

from __future__ import annotations

import datetime as dt
import json
import sqlite3

import msgspec

from base.storage import audit
from schemas.burn_chart import LundBrowderRegion
from schemas.ids import uuid7
from schemas.records import RecordKind
from schemas.wound import Wound

KNOWN_REGIONS = frozenset(r.value for r in LundBrowderRegion)
UPGRADE_LABEL = "burn (before wounds were kept)"
UPGRADE_NOTE = (
    "Made by the upgrade that introduced wounds: it holds every analysis of this patient made before. If the patient "
    "has more than one burn, record the others as wounds and move their pictures to them; set the regions if none "
    "are listed."
)


def give_each_patient_a_wound(conn: sqlite3.Connection) -> None:
    factory, conn.row_factory = conn.row_factory, sqlite3.Row
    try:
        patients = [r[0] for r in conn.execute("SELECT DISTINCT patient_id FROM analysis_jobs ORDER BY patient_id")]
        for patient_id in patients:
            _wound_for(conn, patient_id)
    finally:
        conn.row_factory = factory


def _wound_for(conn: sqlite3.Connection, patient_id: str) -> None:
    wound = Wound(
        id=uuid7(),
        patient_id=patient_id,
        regions=_charted_regions(conn, patient_id),
        label=UPGRADE_LABEL,
        time_of_injury=_latest_injury(conn, patient_id),
        notes=UPGRADE_NOTE,
    )
    audit.insert_server_record(
        conn,
        kind=RecordKind.wound,
        record_id=wound.id,
        parent_id=patient_id,
        data=msgspec.json.encode(wound),
        action="wound.upgrade",
        detail="one wound for the analyses made before wounds were kept",
    )
    conn.execute("UPDATE analysis_jobs SET wound_id = ? WHERE patient_id = ?", (wound.id, patient_id))
    conn.execute(
        "UPDATE assets SET wound_id = ? WHERE encounter_id IN"
        " (SELECT DISTINCT encounter_id FROM analysis_jobs WHERE patient_id = ?)",
        (wound.id, patient_id),
    )


def _encounters(conn: sqlite3.Connection, patient_id: str) -> list[dict]:
    rows = conn.execute(
        "SELECT h.id, v.data FROM record_heads h JOIN record_versions v ON v.seq = h.seq"
        " WHERE h.kind = 'encounter' AND h.parent_id = ? AND h.deleted = 0",
        (patient_id,),
    ).fetchall()
    return [{"id": r["id"], **json.loads(r["data"])} for r in rows]


def _charted_regions(conn: sqlite3.Connection, patient_id: str) -> list[LundBrowderRegion]:
    regions: dict[LundBrowderRegion, None] = {}
    for encounter in _encounters(conn, patient_id):
        row = conn.execute(
            "SELECT v.data FROM record_heads h JOIN record_versions v ON v.seq = h.seq"
            " WHERE h.kind = 'burn_chart' AND h.parent_id = ? AND h.deleted = 0",
            (encounter["id"],),
        ).fetchone()
        for entry in json.loads(row["data"]).get("entries", []) if row else []:
            if entry.get("region") in KNOWN_REGIONS:
                regions[LundBrowderRegion(entry["region"])] = None
    return list(regions)


def _latest_injury(conn: sqlite3.Connection, patient_id: str) -> dt.datetime | None:
    dated = [e for e in _encounters(conn, patient_id) if e.get("time_of_injury") and e.get("time_of_arrival")]
    if not dated:
        return None
    latest = max(dated, key=lambda e: dt.datetime.fromisoformat(e["time_of_arrival"]))
    return dt.datetime.fromisoformat(latest["time_of_injury"])
