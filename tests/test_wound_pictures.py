"""Pictures and analyses belong to a wound, over the real app (no worker runs the analyses queued here): the tus
upload's wound, moving a picture, and which wound an analysis request means or why it is refused; a picture set
aside (it stops counting, is kept and can be put back) and the pictures page's order."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from base.storage import assets as asset_rows
from base.storage import audit
from harness.bodies import encounter_body, patient_body, wound_body
from schemas.config import Config, GatewayConfig, JobsConfig
from tests.capture_images import jpeg, scene
from tests.conftest import FAST_SECURITY
from tests.pages_helpers import post_form, sign_in
from tests.test_uploads import TUS, meta, send

VIEWS = 5
"""The reconstruction's minimum of views (ReconstructionConfig.min_views)."""


@pytest.fixture
def config(tmp_path: Path) -> Config:
    """No worker: the analyses stay queued, so a test reads what was asked for without running COLMAP."""
    database = str(tmp_path / "gateway.sqlite3")
    return Config(gateway=GatewayConfig(database=database), jobs=JobsConfig(workers=0), security=FAST_SECURITY)


@pytest.fixture
def visit(client, auth) -> dict:
    p = patient_body()
    client.post("/api/v1/patients", json=p, headers=auth["clinician"])
    e = encounter_body(p["id"])
    client.post("/api/v1/encounters", json=e, headers=auth["clinician"])
    return {"patient": p, "encounter": e}


def add_wound(client, auth, patient_id: str, **extra) -> dict:
    body = wound_body(patient_id, **extra)
    assert client.post(f"/api/v1/patients/{patient_id}/wounds", json=body, headers=auth["clinician"]).status_code == 201
    return body


def upload(client, auth, encounter_id: str, seed: int, wound_id: str | None = None):
    data = jpeg(scene(640, 480, seed=seed))
    pairs = {"encounter_id": encounter_id, "filename": f"view_{seed}.jpg"} | (
        {"wound_id": wound_id} if wound_id else {}
    )
    headers = {**auth["nurse"], **TUS, "Upload-Length": str(len(data)), "Upload-Metadata": meta(**pairs)}
    created = client.post("/api/v1/uploads", headers=headers)
    if created.status_code != 201:
        return created
    assert send(client, auth["nurse"], created.headers["location"], data).status_code == 204
    return created


def asset_ids(client, auth, encounter_id: str) -> dict[str, str | None]:
    assets = client.get(f"/api/v1/encounters/{encounter_id}/assets", headers=auth["nurse"]).json()
    return {a["id"]: a["wound_id"] for a in assets}


def analyse(client, auth, encounter_id: str, body: dict):
    return client.post(f"/api/v1/encounters/{encounter_id}/analyses", json=body, headers=auth["clinician"])


def test_one_wound_is_meant_when_the_patient_has_only_one(client, auth, visit):
    enc = visit["encounter"]["id"]
    for seed in range(VIEWS):  # sent before the wound was recorded: they belong to no wound yet
        assert upload(client, auth, enc, seed).status_code == 201
    wound = add_wound(client, auth, visit["patient"]["id"])
    job = analyse(client, auth, enc, {})
    assert job.status_code == 202, job.text
    assert job.json()["wound_id"] == wound["id"] and job.json()["pictures"] == VIEWS


def test_with_two_open_wounds_the_wound_is_required_and_its_pictures_are_used(client, auth, visit):
    patient, enc = visit["patient"]["id"], visit["encounter"]["id"]
    arm = add_wound(client, auth, patient)
    leg = add_wound(client, auth, patient, regions=["lower_leg_right_anterior"], label="right shin", side="right")
    for seed in range(VIEWS):
        assert upload(client, auth, enc, seed, arm["id"]).status_code == 201
    assert upload(client, auth, enc, 99, leg["id"]).status_code == 201

    refused = analyse(client, auth, enc, {})
    assert refused.status_code == 422
    detail = refused.json()["detail"]
    assert "left forearm" in detail and "right shin" in detail and arm["id"] in detail and leg["id"] in detail

    job = analyse(client, auth, enc, {"wound_id": arm["id"]})
    assert job.status_code == 202 and job.json()["wound_id"] == arm["id"]
    assert job.json()["pictures"] == VIEWS  # the shin's picture is left out

    pictures = asset_ids(client, auth, enc)
    shin_picture = next(i for i, w in pictures.items() if w == leg["id"])
    mixed = analyse(client, auth, enc, {"wound_id": arm["id"], "assets": list(pictures)})
    assert mixed.status_code == 422 and "show another wound" in mixed.json()["detail"]

    healed = {**leg, "state": "healed", "state_date": visit["encounter"]["time_of_arrival"][:10]}
    assert (
        client.put(
            f"/api/v1/wounds/{leg['id']}", json=healed, headers={**auth["clinician"], "If-Match": '"1"'}
        ).status_code
        == 200
    )
    again = analyse(client, auth, enc, {"marker_side_mm": 25})  # the one wound still open is meant
    assert again.status_code == 202 and again.json()["wound_id"] == arm["id"]

    # The shin's only picture moved to the arm: the shin has none left to measure.
    moved = client.put(f"/api/v1/assets/{shin_picture}/wound", json={"wound_id": arm["id"]}, headers=auth["nurse"])
    assert moved.status_code == 200 and moved.json()["wound_id"] == arm["id"]
    none_left = analyse(client, auth, enc, {"wound_id": leg["id"]})
    assert none_left.status_code == 422 and "no picture of this wound" in none_left.json()["detail"]


def test_a_wound_of_another_patient_is_refused_on_upload_and_on_a_picture(client, auth, visit):
    enc = visit["encounter"]["id"]
    other = patient_body()
    client.post("/api/v1/patients", json=other, headers=auth["clinician"])
    stranger = add_wound(client, auth, other["id"])
    refused = upload(client, auth, enc, 1, stranger["id"])
    assert refused.status_code == 422 and "not a wound of this patient" in refused.json()["detail"]
    assert asset_ids(client, auth, enc) == {}  # nothing stored

    assert upload(client, auth, enc, 2).status_code == 201
    [picture] = asset_ids(client, auth, enc)
    moved = client.put(f"/api/v1/assets/{picture}/wound", json={"wound_id": stranger["id"]}, headers=auth["nurse"])
    assert moved.status_code == 422 and asset_ids(client, auth, enc) == {picture: None}
    unknown = client.put(f"/api/v1/assets/{picture}/wound", json={"wound_id": "nope"}, headers=auth["nurse"])
    assert unknown.status_code == 400  # not an id at all: the schema's answer


# A picture set aside with a reason no longer counts: not among the views for readiness, not chosen for an analysis,
# not in the case sent; it is kept, audited, and can be put back.


def _readiness(client, auth, enc) -> dict:
    return client.get(f"/api/v1/encounters/{enc}/capture-readiness", headers=auth["nurse"]).json()


def test_a_picture_set_aside_stops_counting_is_kept_and_can_be_put_back(client, auth, visit, services):
    enc = visit["encounter"]["id"]
    for seed in range(VIEWS + 1):
        assert upload(client, auth, enc, seed).status_code == 201
    first = next(iter(asset_ids(client, auth, enc)))
    assert _readiness(client, auth, enc)["views"] == VIEWS + 1

    empty = client.post(f"/api/v1/assets/{first}/set-aside", json={"reason": "  "}, headers=auth["nurse"])
    assert empty.status_code == 422 and "say why" in empty.json()["detail"]
    aside = client.post(f"/api/v1/assets/{first}/set-aside", json={"reason": "blurred"}, headers=auth["nurse"])
    assert aside.status_code == 200, aside.text
    assert aside.json()["set_aside"]["reason"] == "blurred" and aside.json()["set_aside"]["by"]
    assert _readiness(client, auth, enc)["views"] == VIEWS
    assert first in asset_ids(client, auth, enc)  # kept
    with services.db.read() as conn:
        assert first not in [p.id for p in asset_rows.encounter_photos(conn, enc, 100)]  # not in the case sent
        actions = [(e.action, e.detail) for e in audit.entries(conn) if e.record_id == first]
    assert ("asset.set_aside", "blurred") in actions

    named = analyse(client, auth, enc, {"assets": list(asset_ids(client, auth, enc))})
    assert named.status_code == 422 and "set aside" in named.json()["detail"]
    job = analyse(client, auth, enc, {})
    assert job.status_code == 202 and job.json()["pictures"] == VIEWS

    back = client.delete(f"/api/v1/assets/{first}/set-aside", headers=auth["nurse"])
    assert back.status_code == 200 and back.json()["set_aside"] is None
    assert _readiness(client, auth, enc)["views"] == VIEWS + 1


def test_the_pictures_page_puts_the_upload_first_then_retakes_then_usable_then_set_aside(client, auth, visit):
    enc = visit["encounter"]["id"]
    for seed in range(3):
        assert upload(client, auth, enc, seed).status_code == 201
    grey = jpeg(np.full((480, 640, 3), 128, np.uint8))
    headers = {**auth["nurse"], **TUS, "Upload-Length": str(len(grey))}
    created = client.post("/api/v1/uploads", headers={**headers, "Upload-Metadata": meta(encounter_id=enc)})
    assert send(client, auth["nurse"], created.headers["location"], grey).status_code == 204
    sign_in(client, "nurse")
    url = f"/encounters/{enc}/pictures"
    first = next(iter(asset_ids(client, auth, enc)))
    r = post_form(client, f"/pictures/{first}/set-aside", {"reason": "wrong patient"}, from_page=url)
    assert r.status_code == 303
    page = client.get(url).text
    order = [page.index(anchor) for anchor in ('id="upload-heading"', 'id="readiness"', 'id="photos-usable"')]
    assert order == sorted(order)
    assert "Set aside (1): not counted, kept" in page and "wrong patient" in page
    assert "1 set aside, not counted." in page
    assert page.index('id="photos-usable"') < page.index('id="photos-aside"')
    retake = page.index('id="photos-retake"')  # the featureless grey picture: the gate refused it
    assert page.index('id="readiness"') < retake < page.index('id="photos-usable"')
    assets = client.get(f"/api/v1/encounters/{enc}/assets", headers=auth["nurse"]).json()
    refused = [a for a in assets if not a["verdict"]["accepted"] and a["set_aside"] is None]
    assert len(refused) >= 1 and f"To take again ({len(refused)})" in page
    aside_section = page[page.index('id="photos-aside"') :]
    assert re.search(rf'action="/pictures/{first}/put-back"', aside_section)
