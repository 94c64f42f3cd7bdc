"""Wounds on the clinic's pages over the real app: a nurse records two wounds on the patient page, picks the wound
when uploading pictures (stored on the picture) and when asking for an analysis (required with two open wounds,
refused with the wounds named when left out)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from base.storage.assets import assets_of_encounter
from schemas.accounts import Role
from tests.conftest import make_user
from tests.pages_helpers import post_form, sign_in
from tests.test_pages_records import _new_encounter, _new_patient

SKIN = Path(__file__).parent / "fixtures" / "upgrade" / "gateway" / "burnedge-media" / "blobs"


@pytest.fixture
def nurse(client, services):
    make_user(services, "nora", Role.nurse)
    sign_in(client, "nora")
    return client


def _record_wound(client, patient_id: str, **fields):
    page = client.get(f"/patients/{patient_id}")
    record_id = re.search(r'name="id" value="([^"]+)"', page.text.split('id="wounds"', 1)[1]).group(1)
    form = {"id": record_id, **fields}
    r = post_form(client, f"/patients/{patient_id}/wounds/new", form, from_page=f"/patients/{patient_id}")
    assert r.status_code == 303, r.text[:500]
    return record_id, r.headers["location"]


def test_wounds_are_recorded_on_the_patient_page_and_picked_for_pictures_and_analyses(nurse, services):
    patient_id = _new_patient(nurse, given_name="Ada", family_name="Okafor", sex="female")
    encounter_id = _new_encounter(nurse, patient_id)
    assert "No wound recorded yet" in nurse.get(f"/patients/{patient_id}").text

    arm, where = _record_wound(
        nurse, patient_id, label="left forearm", regions=["lower_arm_left_anterior", "hand_left_dorsal"], side="left"
    )
    assert where.endswith(f"#wound-{arm}")
    thigh, _ = _record_wound(nurse, patient_id, label="right thigh", regions="thigh_right_anterior", side="")
    page = nurse.get(f"/patients/{patient_id}").text
    assert "Wounds (2)" in page and "left forearm" in page and "Left forearm, front; Left hand, back" in page

    # A wound with no region is refused with the reason, and nothing is stored.
    _, where = _record_wound(nurse, patient_id, label="somewhere")
    refused = nurse.get(where).text
    assert "Nothing was stored" in refused and "Wounds (2)" in refused

    pictures = nurse.get(f"/encounters/{encounter_id}/pictures").text
    assert f'<option value="{arm}"' in pictures and f'<option value="{thigh}"' in pictures
    photo = next(p for p in sorted(SKIN.rglob("*")) if p.is_file())
    token = re.search(r'name="csrf_token" value="([^"]+)"', pictures).group(1)
    r = nurse.post(
        f"/encounters/{encounter_id}/pictures",
        data={"csrf_token": token, "wound_id": thigh},
        files={"files": ("skin.jpg", photo.read_bytes(), "image/jpeg")},
        follow_redirects=False,
    )
    assert r.status_code == 303
    [stored] = assets_of_encounter(services.db.connection(), encounter_id)
    assert stored.wound_id == thigh
    assert "right thigh" in nurse.get(f"/encounters/{encounter_id}/pictures").text

    analyses = nurse.get(f"/encounters/{encounter_id}/analyses").text
    assert re.search(r'<select id="wound_id" name="wound_id"\s+required', analyses)
    asked = post_form(
        nurse, f"/encounters/{encounter_id}/analyses", {}, from_page=f"/encounters/{encounter_id}/analyses"
    )
    assert asked.status_code == 422
    assert "say which one this analysis measures" in asked.text and "left forearm" in asked.text


def test_a_wound_is_marked_healed_on_the_patient_page_and_a_stale_form_is_refused(nurse, services):
    patient_id = _new_patient(nurse, given_name="Ben", family_name="Ito", sex="male")
    _new_encounter(nurse, patient_id)
    wound_id, _ = _record_wound(nurse, patient_id, label="right hand", regions="hand_right_dorsal", side="right")
    change = {
        "version": "1",
        "label": "right hand",
        "regions": "hand_right_dorsal",
        "side": "right",
        "state": "healed",
        "state_date": "2026-12-05",
        "notes": "re-epithelialised",
    }
    r = post_form(nurse, f"/wounds/{wound_id}/edit", change, from_page=f"/patients/{patient_id}")
    assert r.status_code == 303 and r.headers["location"].endswith(f"#wound-{wound_id}")
    stored = (
        services.db.connection()
        .execute(
            "SELECT v.version, v.data FROM record_heads h JOIN record_versions v ON v.seq = h.seq WHERE h.id = ?",
            (wound_id,),
        )
        .fetchone()
    )
    assert stored[0] == 2 and '"state":"healed"' in stored[1] and '"state_date":"2026-12-05"' in stored[1]
    page = nurse.get(f"/patients/{patient_id}").text
    assert "healed on 2026-12-05" in page

    stale = post_form(
        nurse, f"/wounds/{wound_id}/edit", {**change, "notes": "older"}, from_page=f"/patients/{patient_id}"
    )
    shown = nurse.get(stale.headers["location"]).text
    assert "Nothing was stored" in shown and "now at version 2" in shown

    no_date = {**change, "version": "2", "state": "grafted", "state_date": ""}
    refused = post_form(nurse, f"/wounds/{wound_id}/edit", no_date, from_page=f"/patients/{patient_id}")
    assert "needs state_date" in nurse.get(refused.headers["location"]).text
