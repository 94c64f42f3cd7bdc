"""Requesting analyses over the API (the real app and SQLite file, no worker): checks, idempotency, priority,
cancel, permissions, the patient's record. Running them is tests/test_analysis_jobs.py's part."""

from __future__ import annotations

import base64
from pathlib import Path

import cv2
import numpy as np
import pytest

from burnedge.demo_client import GatewayClient
from harness.bodies import encounter_body, patient_body
from processing.phantom.generate import run as render_phantom
from schemas.errors import NotFound
from schemas.phantom import PhantomShape, PhantomSpec

TINY = {"views": 6, "width": 800, "height": 600}


@pytest.fixture(scope="module")
def photos(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("phantom")
    render_phantom(PhantomSpec(shape=PhantomShape.patch, seed=5, **TINY), out)
    return out


@pytest.fixture
def visit(client, auth, photos) -> tuple[GatewayClient, str, dict[str, str]]:
    """A clinician's client, an encounter, and its uploaded photos (stem -> asset id)."""
    phone = GatewayClient(http=client)
    phone.http.headers.update(auth["clinician"])
    p = patient_body()
    phone.post("/api/v1/patients", p, "patient")
    e = encounter_body(p["id"], mode="consultation")
    phone.post("/api/v1/encounters", e, "encounter")
    assets = {f.stem: phone.upload(f, e["id"])["asset"]["id"] for f in sorted((photos / "images").glob("*.jpg"))}
    return phone, e["id"], assets


def _png(array: np.ndarray) -> str:
    return base64.b64encode(cv2.imencode(".png", array)[1].tobytes()).decode()


def test_an_analysis_is_queued_once_however_often_it_is_asked_for(visit, photos):
    phone, enc, assets = visit
    mask = cv2.imread(str(photos / "masks" / "view_000.png"), cv2.IMREAD_GRAYSCALE)
    body = {"masks": [{"asset_id": assets["view_000"], "png_base64": _png(mask)}]}
    first = phone.http.post(f"/api/v1/encounters/{enc}/analyses", json=body)
    assert first.status_code == 202, first.text
    job = first.json()
    assert job["state"] == "queued" and job["pictures"] == TINY["views"] and job["priority"] == 1
    assert job["queue_position"] == 1 and first.headers["location"] == f"/api/v1/analyses/{job['id']}"
    again = phone.http.post(f"/api/v1/encounters/{enc}/analyses", json=body)
    assert again.status_code == 200 and again.json()["id"] == job["id"]
    other = phone.http.post(f"/api/v1/encounters/{enc}/analyses", json={})  # other masks: another analysis
    assert other.status_code == 202 and other.json()["id"] != job["id"]
    listed = phone.get(f"/api/v1/encounters/{enc}/analyses", "list")
    assert [j["id"] for j in listed] == [job["id"], other.json()["id"]]
    assert phone.http.get(f"/api/v1/analyses/{job['id']}/result").status_code == 409  # not finished yet


def test_emergencies_go_ahead_of_consultations_in_the_queue(visit, photos):
    phone, consult_enc, _ = visit
    consult = phone.post(f"/api/v1/encounters/{consult_enc}/analyses", {}, "consultation analysis")
    p = patient_body()
    phone.post("/api/v1/patients", p, "patient")
    e = encounter_body(p["id"])  # emergency
    phone.post("/api/v1/encounters", e, "encounter")
    for f in sorted((photos / "images").glob("*.jpg")):
        phone.upload(f, e["id"])
    urgent = phone.post(f"/api/v1/encounters/{e['id']}/analyses", {}, "emergency analysis")
    assert urgent["priority"] == 0 and urgent["queue_position"] == 1
    assert phone.get(f"/api/v1/analyses/{consult['id']}", "read")["queue_position"] == 2


def test_a_queued_analysis_is_cancelled_at_once_and_may_be_asked_for_again(visit):
    phone, enc, _ = visit
    job = phone.post(f"/api/v1/encounters/{enc}/analyses", {}, "request")
    cancelled = phone.post(f"/api/v1/analyses/{job['id']}/cancel", {}, "cancel")
    assert cancelled["state"] == "cancelled"
    again = phone.post(f"/api/v1/encounters/{enc}/analyses", {}, "request again")
    assert again["id"] != job["id"] and again["state"] == "queued"


@pytest.mark.parametrize(
    ("make_body", "message"),
    [
        (lambda a: {"assets": list(a.values())[:3]}, "needs at least 5"),
        (lambda a: {"assets": ["0192f3b4-6a8e-7c3d-9b1a-000000000000", *a.values()]}, "not pictures of this encounter"),
        (
            lambda a: {"masks": [{"asset_id": a["view_001"], "png_base64": _png(np.zeros((10, 10), np.uint8))}]},
            "is 10x10 but the picture is 800x600",
        ),
        (lambda a: {"masks": [{"asset_id": a["view_001"], "png_base64": "bm90IGEgcG5n"}]}, "not a PNG"),
        (lambda a: {"masks": [{"asset_id": a["view_001"]}]}, "either png_base64 or polygons"),
        (
            lambda a: {
                "assets": list(a.values())[1:],
                "masks": [{"asset_id": a["view_000"], "polygons": [[[0, 0], [5, 0], [5, 5]]]}],
            },
            "not one of the analysed pictures",
        ),
        (
            lambda a: {
                "ruler": {
                    "distance_mm": 50,
                    "marks": [
                        {"asset_id": a["view_000"], "a": [1, 2], "b": [3, 4]},
                        {"asset_id": "0192f3b4-6a8e-7c3d-9b1a-000000000000", "a": [1, 2], "b": [3, 4]},
                    ],
                }
            },
            "ruler mark on",
        ),
    ],
)
def test_requests_that_cannot_give_an_analysis_are_refused_with_the_reason(visit, make_body, message):
    phone, enc, assets = visit
    r = phone.http.post(f"/api/v1/encounters/{enc}/analyses", json=make_body(assets))
    assert r.status_code == 422 and message in r.json()["detail"], r.text
    assert phone.get(f"/api/v1/encounters/{enc}/analyses", "list") == []


def test_who_may_ask_read_and_what_is_not_there(visit, client, auth, services):
    phone, enc, _ = visit
    consultant = client.post(f"/api/v1/encounters/{enc}/analyses", json={}, headers=auth["consultant"])
    assert consultant.status_code == 403
    job = phone.post(f"/api/v1/encounters/{enc}/analyses", {}, "request")
    assert client.get(f"/api/v1/analyses/{job['id']}", headers=auth["consultant"]).status_code == 200
    assert client.get(f"/api/v1/analyses/{job['id']}", headers=auth["admin"]).status_code == 403
    assert client.get(f"/api/v1/analyses/{job['id']}", headers={"Authorization": "Bearer nope"}).status_code == 401
    assert phone.http.get("/api/v1/analyses/0192f3b4-6a8e-7c3d-9b1a-000000000000").status_code == 404
    missing = phone.http.post("/api/v1/encounters/0192f3b4-6a8e-7c3d-9b1a-000000000000/analyses", json={})
    assert missing.status_code == 404
    from gateway.jobs.folders import artifact_file

    (folders_root := Path(services.config.gateway.database).parent / "burnedge-analyses" / job["id"]).mkdir(
        parents=True
    )
    (folders_root / "analysis").mkdir()
    for escape in ("../../gateway.sqlite3", "../request.json", "/etc/passwd", "analysis.json"):
        with pytest.raises(NotFound):
            artifact_file(services.config, job["id"], escape)
    r = phone.http.get(f"/api/v1/analyses/{job['id']}/artifacts/%2e%2e%2f%2e%2e%2fgateway.sqlite3")
    assert r.status_code == 404
    # No wound recorded and nothing measured yet: no section, rather than a track mixing anything.
    assert phone.get(f"/api/v1/patients/{job['patient_id']}/healing", "healing")["wounds"] == []
