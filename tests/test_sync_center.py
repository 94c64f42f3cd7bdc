"""A clinic gateway and a burn center, each a real process, talking Zenoh over TCP on loopback."""

from __future__ import annotations

from pathlib import Path

import pytest

from harness.processes import free_port
from harness.report_pages import page_texts
from harness.sites import CLINIC, CenterProcess, Sites, noise_photo, record_case, wait_for

pytestmark = pytest.mark.server


def delivered(client, encounter_id: str, version: int):
    entries = client.get(f"/api/v1/encounters/{encounter_id}/transfers", "transfers")
    return next((e for e in entries if e["version"] == version and e["state"] == "delivered"), None)


@pytest.fixture
def sites(tmp_path: Path, center_database: str):
    """Both sites set up, the center on SQLite or on PostgreSQL."""
    sites = Sites(tmp_path, center_database=center_database)
    sites.set_up()
    yield sites
    sites.stop()


def test_case_arrives_intact_and_advice_comes_back(sites: Sites, tmp_path: Path):
    sites.center.start()
    sites.gateway.start()
    clinic = sites.clinic_client()
    encounter_id, photos = record_case(clinic, tmp_path, photos=2)

    sent = clinic.http.post(f"/api/v1/encounters/{encounter_id}/transfers")
    assert sent.status_code == 202, sent.text
    entry = wait_for(lambda: delivered(clinic, encounter_id, 1), 30, "delivery of version 1")
    assert entry["bundle_id"] == sent.json()["bundle_id"]

    center = sites.center_client()
    cases = center.get("/api/v1/cases", "cases")["cases"]
    assert [c["encounter_id"] for c in cases] == [encounter_id]
    assert cases[0]["awaiting_advice"] and cases[0]["site_name"] == "Test field clinic"
    detail = center.get(f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}", "case")
    names = [p["name"] for p in detail["manifest"]["parts"]]
    received = sorted(
        center.http.get(f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}/parts/{n}").content
        for n in names
        if n.startswith("photos/")
    )
    assert received == sorted(p.read_bytes() for p in photos)  # byte-identical after decryption
    record = center.http.get(f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}/parts/record.json").json()
    assert record["encounter"]["meta"]["id"] == encounter_id
    # The consultant reads the same clinical report the clinic prints.
    report = center.http.get(f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}/parts/report.pdf")
    assert report.headers["content-type"] == "application/pdf" and report.content.startswith(b"%PDF")
    assert encounter_id in " ".join(page_texts(report.content))

    note = center.post(
        f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}/notes",
        {
            "recommendation": "manage_locally",
            "advice": "Dress with silver sulfadiazine; review in 48 h with new photos.",
        },
        "note",
    )
    notes = wait_for(
        lambda: clinic.get(f"/api/v1/encounters/{encounter_id}/consultations", "notes"),
        30,
        "the consultant's note at the clinic",
    )
    assert len(notes) == 1
    got = notes[0]["data"]["note"]
    assert got["note_id"] == note["note"]["note_id"] and got["consultant"] == "Dr Consultant"
    assert got["advice"].startswith("Dress with silver") and notes[0]["data"]["signed_by"] == "center-test"
    wait_for(
        lambda: center.get(f"/api/v1/cases/{cases[0]['site_id']}/{entry['bundle_id']}", "case")["notes"][0][
            "delivered_at"
        ],
        30,
        "the clinic's acknowledgement of the note",
    )

    # Nothing changed: no second version. Another photo: version 2 supersedes version 1, which stays readable.
    again = clinic.http.post(f"/api/v1/encounters/{encounter_id}/transfers")
    assert again.status_code == 200 and again.json()["unchanged"] and again.json()["version"] == 1
    clinic.upload(noise_photo(tmp_path / "later.jpg", 99), encounter_id)
    assert clinic.http.post(f"/api/v1/encounters/{encounter_id}/transfers").json()["version"] == 2
    second = wait_for(lambda: delivered(clinic, encounter_id, 2), 30, "delivery of version 2")
    latest = center.get("/api/v1/cases", "cases")["cases"]
    assert [(c["bundle_id"], c["version"]) for c in latest] == [(second["bundle_id"], 2)]
    everything = center.get("/api/v1/cases?include_superseded=true", "all versions")["cases"]
    assert {c["version"]: c["superseded_by"] for c in everything} == {1: second["bundle_id"], 2: None}
    assert sites.center.rows("SELECT COUNT(*) FROM bundles") == [(2,)]
    assert sites.center.rows("SELECT COUNT(*) FROM incoming") == [(0,)]


def sent_chunks(client, encounter_id: str) -> int:
    entries = client.get(f"/api/v1/encounters/{encounter_id}/transfers", "transfers")
    return entries[0]["sent_chunks"] if entries and entries[0]["state"] == "queued" else 0


def test_sigkill_of_either_side_mid_transfer_still_stores_each_bundle_once(tmp_path: Path):
    """On SQLite: with PostgreSQL, tests/test_center_router.py kills one of two workers the same way."""
    from harness.poor_link import ThrottlingProxy

    zenoh_port = free_port()
    with ThrottlingProxy("127.0.0.1", zenoh_port, rate_kbit=4000) as proxy:  # ~1 s per 0.5 MB: time to kill
        sites = Sites(
            tmp_path,
            center_endpoint=f"tcp/127.0.0.1:{proxy.port}",
            zenoh_port=zenoh_port,
        )
        sites.gateway.env["BURNEDGE_SYNC_CHUNK_KIB"] = "64"
        sites.set_up()
        try:
            sites.center.start()
            sites.gateway.start()
            clinic = sites.clinic_client()
            first, first_photos = record_case(clinic, tmp_path, photos=3, seed=1)
            clinic.http.post(f"/api/v1/encounters/{first}/transfers")
            wait_for(lambda: sent_chunks(clinic, first) >= 4, 60, "the first chunks acknowledged")
            sites.center.kill()
            sites.center.start()
            one = wait_for(lambda: delivered(clinic, first, 1), 120, "delivery after the center's restart")

            second, second_photos = record_case(clinic, tmp_path, photos=3, seed=2)
            clinic.http.post(f"/api/v1/encounters/{second}/transfers")
            wait_for(lambda: sent_chunks(clinic, second) >= 4, 60, "the second bundle's first chunks")
            sites.gateway.proc.kill()
            sites.gateway.proc.wait()
            sites.gateway.start()
            clinic = sites.clinic_client()
            two = wait_for(lambda: delivered(clinic, second, 1), 120, "delivery after the clinic's restart")

            center = sites.center_client()
            for entry, photos in ((one, first_photos), (two, second_photos)):
                assert photos_at_center(center, entry["bundle_id"]) == sorted(p.read_bytes() for p in photos)
        finally:
            sites.stop()
    assert_stored_once(sites.center, [one["bundle_id"], two["bundle_id"]])


def photos_at_center(center, bundle_id: str) -> list[bytes]:
    """The photos of the clinic's bundle as the center's API serves them, sorted."""
    detail = center.get(f"/api/v1/cases/{CLINIC}/{bundle_id}", "case")
    return sorted(
        center.http.get(f"/api/v1/cases/{CLINIC}/{bundle_id}/parts/{p['name']}").content
        for p in detail["manifest"]["parts"]
        if p["name"].startswith("photos/")
    )


def assert_stored_once(center: CenterProcess, bundle_ids: list[str]) -> None:
    """Each bundle stored once and nothing else; no transfer left open, no staged chunk left behind."""
    rows = center.rows("SELECT bundle_id, COUNT(*) FROM bundles GROUP BY bundle_id")
    assert sorted(r[0] for r in rows) == sorted(bundle_ids)
    assert all(count == 1 for _, count in rows)
    assert center.rows("SELECT COUNT(*) FROM incoming") == [(0,)]
    staging = center.folder / "burnedge-central-store" / "incoming"
    assert not any(p.is_file() for p in staging.rglob("*")), "staged chunks left behind"
