"""Linking a clinic and a burn center on the two administrators' pages, over the real apps (TestClient): keys made,
exchanged as a file and as a photo of a QR code, enrolled only once the fingerprints were compared, the link
switched on without a restart; wrong input refused with a message and nothing stored.
(tests/test_browser_link.py does it in a real browser between two real processes, with a case and advice after.)"""

from __future__ import annotations

import io

import cv2
import numpy as np
import pytest
import segno
from litestar.testing import TestClient

from base.folders import keys_dir
from center.app import CentralServices, create_central_app, open_center_db
from schemas.accounts import Role, UserCreate
from schemas.config import CentralConfig, Config, GatewayConfig, SyncConfig
from schemas.transfer import SiteRole
from sync import peers
from sync.keys import PRIVATE_FILE, fingerprint, init_keys
from sync.link_card import card_json
from tests.conftest import FAST_SECURITY, make_user
from tests.pages_helpers import post_form, sign_in

CENTER_ENDPOINT = "tcp/127.0.0.1:9"
"""Nothing listens there: the round that the link starts fails at once, as it would with the center down."""


@pytest.fixture
def config(tmp_path) -> Config:
    """The clinic's; a round to the unreachable test address gives up at once (the app waits for it on closing)."""
    gateway = GatewayConfig(database=str(tmp_path / "gateway.sqlite3"))
    return Config(gateway=gateway, security=FAST_SECURITY, sync=SyncConfig(connect_timeout_s=0.3))


@pytest.fixture
def admin(client, services):
    make_user(services, "ada", Role.admin)
    sign_in(client, "ada", next="/transfers")
    return client


@pytest.fixture
def center(tmp_path):
    central = CentralConfig(
        database=str(tmp_path / "center.sqlite3"),
        keys_dir=str(tmp_path / "center-keys"),
        store_dir=str(tmp_path / "center-store"),
        listen_endpoints=[CENTER_ENDPOINT],
    )
    config = Config(central=central, security=FAST_SECURITY)
    init_keys(tmp_path / "center-keys", "center-kampala", SiteRole.center, "Kampala burn centre")
    db = open_center_db(central)
    services = CentralServices.build(config, db)
    services.accounts.create_user(None, UserCreate(username="it", password="a-long-password", role=Role.admin))
    with TestClient(create_central_app(config, services)) as client:
        sign_in(client, "it", password="a-long-password", next="/clinics")
        yield client, services
    db.close()


def _qr_photo(data: bytes) -> bytes:
    """A phone-like photo of a QR code on a screen: grey surround, slightly blurred, JPEG."""
    buffer = io.BytesIO()
    segno.make(data, error="m").save(buffer, kind="png", scale=6, border=4)
    code = cv2.imdecode(np.frombuffer(buffer.getvalue(), np.uint8), cv2.IMREAD_GRAYSCALE)
    photo = np.full((code.shape[0] + 400, code.shape[1] + 600), 150, np.uint8)
    photo[200 : 200 + code.shape[0], 300 : 300 + code.shape[1]] = code
    return cv2.imencode(".jpg", cv2.GaussianBlur(photo, (3, 3), 0), [cv2.IMWRITE_JPEG_QUALITY, 85])[1].tobytes()


def _upload(client, url: str, name: str, content: bytes, from_page: str):
    from tests.pages_helpers import csrf_from

    token = csrf_from(client.get(from_page).text)
    return client.post(url, data={"csrf_token": token}, files={"card": (name, content)})


def test_only_the_administrator_links_and_a_nurse_sees_the_state(client, services):
    make_user(services, "nina", Role.nurse)
    sign_in(client, "nina", next="/transfers")
    page = client.get("/transfers").text
    assert "The clinic's administrator links it" in page and "Make this clinic's keys" not in page
    r = post_form(client, "/transfers/link/keys", {"site_id": "clinic-x", "name": "X"}, from_page="/transfers")
    assert r.status_code == 403


def test_the_clinic_links_to_the_center_with_a_file_one_way_and_a_qr_photo_the_other(admin, services, config, center):
    center_client, center_services = center
    # 1. The clinic's keys: a bad site id is refused with a message and makes nothing.
    r = post_form(
        admin, "/transfers/link/keys", {"site_id": "Kasese Clinic!", "name": "Kasese"}, from_page="/transfers"
    )
    assert r.status_code == 422 and "not usable" in r.text
    assert not (keys_dir(config) / PRIVATE_FILE).exists()
    r = post_form(
        admin,
        "/transfers/link/keys",
        {"site_id": "clinic-kasese", "name": "Kasese field clinic"},
        from_page="/transfers",
    )
    assert r.status_code == 303
    page = admin.get(r.headers["location"]).text
    assert "keys were made" in page and "<svg" in page
    clinic_identity = services.transfers.sync.keys().identity
    clinic_print = fingerprint(clinic_identity)
    assert clinic_print.split(" ")[0] in page

    # The center reads the clinic's keys file: shown with the same fingerprint, nothing enrolled yet.
    keys_file = admin.get("/transfers/link/site.pub.json")
    assert keys_file.headers["content-disposition"].startswith("attachment")
    r = _upload(center_client, "/clinics/read", "clinic-kasese.pub.json", keys_file.content, "/clinics")
    assert r.status_code == 200 and clinic_print.split(" ")[-1] in r.text and "Kasese field clinic" in r.text
    assert peers.list_peers(center_services.db) == []
    card = r.text.split('name="card" value="')[1].split('"')[0].replace("&#34;", '"').replace("&quot;", '"')
    r = post_form(center_client, "/clinics/enrol", {"card": card}, from_page="/clinics")
    assert r.status_code == 422 and "compare the fingerprint" in r.text
    assert peers.list_peers(center_services.db) == []
    r = post_form(center_client, "/clinics/enrol", {"card": card, "compared": "yes"}, from_page="/clinics")
    assert r.status_code == 303
    assert "Kasese field clinic" in center_client.get("/clinics").text
    (enrolled,) = peers.list_peers(center_services.db)
    assert enrolled.identity == clinic_identity and enrolled.enrolled_by == "it"

    # The clinic reads the center's QR code from a photo; a photo with no code says what to do.
    blank = cv2.imencode(".jpg", np.full((300, 300), 200, np.uint8))[1].tobytes()
    r = _upload(admin, "/transfers/link/center", "blank.jpg", blank, "/transfers")
    assert r.status_code == 422 and "no QR code could be read" in r.text
    wrong = _upload(admin, "/transfers/link/center", "mine.json", card_json(clinic_identity), "/transfers")
    assert wrong.status_code == 422 and "keys of a clinic" in wrong.text
    center_identity = center_services.keys.identity
    assert fingerprint(center_identity).split(" ")[0] in center_client.get("/clinics").text
    from msgspec import json

    r = _upload(admin, "/transfers/link/center", "qr.jpg", _qr_photo(json.encode(center_identity)), "/transfers")
    assert r.status_code == 200 and "Kampala burn centre" in r.text
    assert fingerprint(center_identity).split(" ")[-1] in r.text
    card = json.encode(center_identity).decode()
    r = post_form(admin, "/transfers/link/center/enrol", {"card": card, "compared": "yes"}, from_page="/transfers")
    assert r.status_code == 303
    assert peers.only_center(services.db.connection()).site_id == "center-kampala"

    # 3. The link: a wrong address is refused; on, it is what the next round uses, without a restart.
    r = post_form(
        admin, "/transfers/link/settings", {"endpoints": "203.0.113.5", "enabled": "yes"}, from_page="/transfers"
    )
    assert r.status_code == 422 and "protocol/host:port" in r.text
    assert not services.transfers.sync.effective_config().sync.enabled
    r = post_form(
        admin, "/transfers/link/settings", {"endpoints": CENTER_ENDPOINT, "enabled": "yes"}, from_page="/transfers"
    )
    assert r.status_code == 303
    effective = services.transfers.sync.effective_config().sync
    assert effective.enabled and effective.center_endpoints == [CENTER_ENDPOINT]
    status = services.transfers.sync.status()
    assert status.enabled and status.center_id == "center-kampala" and status.link_set_by == "ada"
    page = admin.get(r.headers["location"]).text
    assert "The link is on" in page and CENTER_ENDPOINT in page


def test_a_site_id_already_enrolled_with_other_keys_is_not_replaced_silently(center, tmp_path):
    center_client, center_services = center
    first = init_keys(tmp_path / "a", "clinic-a", SiteRole.clinic, "Clinic A").identity
    other = init_keys(tmp_path / "b", "clinic-a", SiteRole.clinic, "Another clinic").identity
    peers.enrol(center_services.db, first, by="it")
    from msgspec import json

    r = post_form(
        center_client, "/clinics/enrol", {"card": json.encode(other).decode(), "compared": "yes"}, from_page="/clinics"
    )
    assert r.status_code == 409 and "already enrolled" in r.text
    assert peers.list_peers(center_services.db)[0].identity == first
    r = post_form(center_client, "/clinics/clinic-a/unlink", {"reason": ""}, from_page="/clinics")
    assert r.status_code == 422 and "say why" in r.text
    r = post_form(center_client, "/clinics/clinic-a/unlink", {"reason": "closed"}, from_page="/clinics")
    assert r.status_code == 303
    assert "unlinked" in center_client.get("/clinics").text
    assert peers.list_peers(center_services.db)[0].revoked_at is not None
