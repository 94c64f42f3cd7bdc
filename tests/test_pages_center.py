"""The burn center's pages for consultants over the real center app (TestClient): the case list, the case page with
the clinic's record, 3D viewer, photos and report, advice written through the form and followed to its delivery,
roles, CSRF and escaping.

The case is real (tests/center_pair.py): a clinic gateway in this process records a patient, an encounter with a
burn chart, two wounds and a photo, and sends it with its own sync round over Zenoh on loopback to the center's own
endpoint, also in this process. The record's history, ABCDE and decision support on the case page: test_pages_center_record.py.
"""

from __future__ import annotations

import html as html_text
import re
from pathlib import Path

import msgspec
import pytest
from litestar.testing import TestClient

from center.app import create_central_app
from gateway.records import snapshot as encounter_reading
from harness.bodies import encounter_body, now, patient_body, wound_body
from harness.sites import noise_photo
from schemas.transfer import CaseSummary, CaseWound
from schemas.wound_healing import BodyShare
from tests.center_pair import SURFACE, Pair, center_pair, store_analysis
from tests.pages_helpers import post_form, sign_in

NAME = "<script>alert(1)</script>"
ARM, THIGH = "left upper arm", "right thigh"
FLAG = (
    "The burn chart records no burn in the wound's regions, but 0.10 %TBSA was measured there: check the chart and "
    "the wound's regions."
)


def _with_a_measured_arm(real):
    """healing.json as the clinic sends it once the arm has a measured visit: the track behind it needs a 3D
    reconstruction, so its share is given here (the arm is not on the chart: the clinic's check flags it)."""

    def patient_healing(conn, config, patient_id, wounds):
        healing = real(conn, config, patient_id, wounds)
        share = BodyShare(
            measured_percent=0.1,
            measured_area_cm2=18.4,
            measured_by="/api/v1/analyses/arm",
            measured_day=0.0,
            charted_percent=0.0,
            regions_percent=2.0,
            charted_by="burn_chart of this encounter",
            flag=FLAG,
        )
        sections = [msgspec.structs.replace(w, share=share) if w.label == ARM else w for w in healing.wounds]
        return msgspec.structs.replace(healing, wounds=sections)

    return patient_healing


def _record_case(pair: Pair, folder: Path) -> None:
    api = pair.api
    patient = api.post("/api/v1/patients", patient_body(given_name=NAME), "patient")
    patient_id = patient["meta"]["id"]
    encounter_id = api.post("/api/v1/encounters", encounter_body(patient_id), "encounter")["meta"]["id"]
    arm, thigh = (
        api.post(
            f"/api/v1/patients/{patient_id}/wounds",
            wound_body(patient_id, label=label, regions=[region], side=side),
            "wound",
        )
        for label, region, side in ((ARM, "upper_arm_left_anterior", "left"), (THIGH, "thigh_right_anterior", "right"))
    )
    chart = {
        "encounter_id": encounter_id,
        "assessed_at": now().isoformat(),
        "entries": [
            {"region": "trunk_anterior", "fraction": 1.0, "depth": "deep_partial"},
            {"region": "thigh_right_anterior", "fraction": 1.0, "depth": "full_thickness"},
        ],
    }
    r = api.http.put(f"/api/v1/encounters/{encounter_id}/burn-chart", json=chart, headers={"If-None-Match": "*"})
    assert r.status_code == 201, r.text
    photo = api.upload(noise_photo(folder / "photo.jpg", 1, size=(640, 480)), encounter_id)
    store_analysis(pair, encounter_id, [photo["asset"]["id"]], wound_id=arm["meta"]["id"])
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(encounter_reading, "patient_healing", _with_a_measured_arm(encounter_reading.patient_healing))
        pair.send(encounter_id)


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pair")
    with center_pair(folder) as pair:
        _record_case(pair, folder)
        yield pair


@pytest.fixture
def consultant(pair):
    with pair.consultant() as client:
        yield client


def test_the_case_list_shows_the_received_case_by_urgency_with_its_clinic_and_age(pair, consultant):
    assert consultant.get("/", follow_redirects=False).headers["location"] == "/cases"
    page = consultant.get("/cases")
    assert page.status_code == 200
    assert f'href="{pair.case_url}"' in page.text
    assert "Test field clinic" in page.text and "min ago" in page.text
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in page.text and NAME not in page.text  # by the patient's name
    assert "badge-urgent" in page.text and ">immediate<" in page.text  # full thickness: an immediate referral
    assert "17.8 %" in page.text and "18.4 cm²" in page.text  # %TBSA 13 + 4.75, and the 3D area
    assert 'href="/cases?include_superseded=true"' in page.text
    assert "Latest versions only" in consultant.get("/cases?include_superseded=true").text


def test_the_case_list_filters_by_urgency_and_clinic_and_says_what_is_wrong_with_a_filter(pair, consultant):
    picked = consultant.get("/cases", params={"urgency": "immediate", "site_id": "clinic-test", "state": ""})
    assert picked.status_code == 200 and f'href="{pair.case_url}"' in picked.text
    assert "1 case matches these filters" in picked.text and '<option value="immediate" selected>' in picked.text
    none = consultant.get("/cases", params={"urgency": "routine"})
    assert none.status_code == 200 and pair.case_url not in none.text and "No case matches these filters" in none.text
    wrong = consultant.get("/cases", params={"received_from": "4 March"})
    assert wrong.status_code == 422 and "received_from" in wrong.text and "YYYY-MM-DD" in wrong.text
    api = consultant.get("/api/v1/cases", params={"limit": "0"})
    assert api.status_code == 422 and api.json()["errors"] == [{"field": "$.limit", "message": "Expected `int` >= 1"}]
    unknown = consultant.get("/api/v1/cases", params={"sort": "name"}).json()
    assert unknown["detail"] == "query parameter `sort`: not a parameter this list takes"
    page = consultant.get("/api/v1/cases", params={"limit": "1"}).json()
    assert page["total"] == 1 and page["next_after"] is None and len(page["cases"]) == 1


def test_the_case_page_shows_the_record_the_viewer_photos_report_and_versions(pair, consultant):
    page = consultant.get(pair.case_url)
    assert page.status_code == 200
    html = page.text
    assert "Test field clinic" in html and "70.0 kg" in html and "Dr. Test" in html
    assert "17.8 %" in html and "Oral fluids" in html  # the clinic's %TBSA and fluids (below 20 %)
    assert "3 criteria met" in html and "Thermal: full-thickness burns (any size)" in html
    glb = f"{pair.parts_url}analyses/{pair.job_id}/{SURFACE}"
    assert re.search(rf'<model-viewer id="surface-viewer" src="{re.escape(glb)}"', html)
    assert '<script type="module" src="/static/vendor/model-viewer/model-viewer.min.js">' in html
    assert consultant.get(glb).content.startswith(b"glTF")  # the part URL works with the page's cookie
    assert "18.4 cm²" in html and "17.2 cm" in html and "1.6 mm" in html and "geometry, not burn depth" in html
    assert "marker (± 1.5 %)" in html and "high (0.86)" in html
    photo = re.search(rf'<img src="({re.escape(pair.parts_url)}photos/[^"]+)"', html)
    assert photo and consultant.get(photo.group(1)).headers["content-type"] == "image/jpeg"
    report = re.search(rf'href="({re.escape(pair.parts_url)}report\.pdf)"', html)
    assert report and consultant.get(report.group(1)).content.startswith(b"%PDF")
    assert "<strong>Version 1</strong> (this one)" in html


def test_each_wound_is_summarised_and_shown_with_its_analyses_area_and_share_of_the_body(pair, consultant):
    detail = consultant.get(f"/api/v1/cases/clinic-test/{pair.bundle_id}").json()
    summary = msgspec.convert(detail["manifest"]["summary"], CaseSummary)
    assert [(w.label, w.regions, w.state, w.analyses, w.area_cm2) for w in summary.wounds] == [
        (ARM, ["upper_arm_left_anterior"], "open", 1, 18.4),
        (THIGH, ["thigh_right_anterior"], "open", 0, None),
    ]
    assert all(isinstance(w, CaseWound) for w in summary.wounds)
    page = html_text.unescape(consultant.get(pair.case_url).text)
    wounds = page.split('id="wounds"', 1)[1].split("</section>", 1)[0]
    arm, thigh = wounds.split('<article class="wound"')[1:]
    assert f"<h3>{ARM}</h3>" in arm and "Left upper arm, front (left)" in arm and "<dd>open</dd>" in arm
    assert "1 in this encounter" in arm and "18.4 cm²" in arm
    assert "0.10 %TBSA (18.4 cm² on day 0; the wound's latest measured area (3D, cm2)" in arm
    assert "0.00 %TBSA of the wound's regions (2.00 %TBSA in all); the burn chart's Lund-Browder estimate" in arm
    assert "Check: The burn chart records no burn in the wound's regions, but 0.10 %TBSA was measured there" in arm
    assert f"<h3>{THIGH}</h3>" in thigh and "Right thigh, front (right)" in thigh and "0 in this encounter" in thigh
    assert "<dd>—</dd>" in thigh and "No measured visit in cm² yet" in thigh and "%TBSA" not in thigh


def test_a_patient_name_with_markup_is_shown_as_text(pair, consultant):
    html = consultant.get(pair.case_url).text
    assert NAME not in html
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html


def test_advice_written_through_the_form_is_listed_and_followed_to_its_delivery(pair, consultant):
    before = pair.note_count()
    r = post_form(
        consultant,
        f"{pair.case_url}/notes",
        {"recommendation": "transfer", "advice": "Transfer today; keep the patient warm."},
        from_page=pair.case_url,
    )
    assert r.status_code == 303 and r.headers["location"] == f"{pair.case_url}?written=1"
    page = consultant.get(r.headers["location"]).text
    assert "Advice written" in page and "Transfer today; keep the patient warm." in page
    assert 'data-note-state="queued"' in page and "Dr Consultant" in page
    assert pair.note_count() == before + 1
    pair.sync_round()  # the clinic fetches the note, stores it and says so in the same round
    assert 'data-note-state="delivered"' in consultant.get(pair.case_url).text
    assert ">written<" in consultant.get("/cases").text


def test_invalid_advice_shows_the_form_again_with_errors_and_stores_nothing(pair, consultant):
    before = pair.note_count()
    r = post_form(
        consultant,
        f"{pair.case_url}/notes",
        {"recommendation": "teleport", "advice": "Something"},
        from_page=pair.case_url,
    )
    assert r.status_code == 422
    assert 'aria-invalid="true"' in r.text and "Something" in r.text
    assert pair.note_count() == before


def test_a_post_without_the_csrf_token_is_refused(pair, consultant):
    before = pair.note_count()
    r = consultant.post(
        f"{pair.case_url}/notes", data={"recommendation": "transfer", "advice": "forged"}, follow_redirects=False
    )
    assert r.status_code == 403
    assert pair.note_count() == before


def test_the_administrator_is_refused_a_case_page_as_by_the_api(pair):
    with TestClient(create_central_app(pair.center_config, pair.center)) as client:
        sign_in(client, "it", next="/admin")
        assert client.get("/", follow_redirects=False).headers["location"] == "/admin"
        assert client.get(pair.case_url).status_code == 403
        assert client.get(f"/api/v1/cases/clinic-test/{pair.bundle_id}").status_code == 403


def test_signed_out_pages_go_to_the_sign_in(pair):
    with TestClient(create_central_app(pair.center_config, pair.center)) as client:
        r = client.get(pair.case_url, follow_redirects=False)
        assert r.status_code == 303 and r.headers["location"].startswith("/sign-in?next=")
