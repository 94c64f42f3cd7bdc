"""A picture set aside with a reason no longer counts: not among the views for readiness, not chosen for an
analysis, not in the case sent; it is kept, audited, and can be put back. Over the real app (no worker runs the
analyses queued here), through the API and the pictures page."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from base.storage import assets as asset_rows
from base.storage import audit
from harness.bodies import encounter_body, patient_body
from schemas.config import Config, GatewayConfig, JobsConfig
from tests.capture_images import jpeg
from tests.conftest import FAST_SECURITY
from tests.pages_helpers import post_form, sign_in
from tests.test_uploads import TUS, meta, send
from tests.test_wound_pictures import VIEWS, analyse, asset_ids, upload


@pytest.fixture
def config(tmp_path: Path) -> Config:
    """No worker: the analyses stay queued (nothing here needs COLMAP)."""
    database = str(tmp_path / "gateway.sqlite3")
    return Config(gateway=GatewayConfig(database=database), jobs=JobsConfig(workers=0), security=FAST_SECURITY)


@pytest.fixture
def visit(client, auth) -> dict:
    p = patient_body()
    client.post("/api/v1/patients", json=p, headers=auth["clinician"])
    e = encounter_body(p["id"])
    client.post("/api/v1/encounters", json=e, headers=auth["clinician"])
    return {"patient": p, "encounter": e}


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
