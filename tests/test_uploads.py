"""tus uploads in the real app: the protocol, every kind of bad input, and what gets stored."""

from __future__ import annotations

import base64
import hashlib
import os

import pytest

from harness.bodies import encounter_body, patient_body
from schemas.ids import uuid7
from tests.capture_images import heic, jpeg, jpeg_with_exif, png_bomb, scene, video

TUS = {"Tus-Resumable": "1.0.0"}
OCTETS = {"Content-Type": "application/offset+octet-stream"}


def meta(**pairs: str) -> str:
    return ",".join(f"{k} {base64.b64encode(v.encode()).decode()}" for k, v in pairs.items())


@pytest.fixture
def enc(client, auth) -> str:
    p = patient_body()
    client.post("/api/v1/patients", json=p, headers=auth["clinician"])
    e = encounter_body(p["id"])
    client.post("/api/v1/encounters", json=e, headers=auth["clinician"])
    return e["id"]


def create(client, headers, enc: str, length: int, filename: str = "IMG_0001.JPG"):
    return client.post(
        "/api/v1/uploads",
        headers={
            **headers,
            **TUS,
            "Upload-Length": str(length),
            "Upload-Metadata": meta(encounter_id=enc, filename=filename),
        },
    )


def send(client, headers, location: str, data: bytes, offset: int = 0, **extra):
    return client.patch(
        location, content=data, headers={**headers, **TUS, **OCTETS, "Upload-Offset": str(offset), **extra}
    )


def upload(client, headers, enc: str, data: bytes, filename: str = "IMG_0001.JPG"):
    r = create(client, headers, enc, len(data), filename)
    assert r.status_code == 201, r.text
    return r.headers["location"], send(client, headers, r.headers["location"], data)


def stored_files(services) -> list[str]:
    root = services.assets.store.root
    return sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())


def test_options_advertises_the_tus_extensions_without_a_session(client):
    r = client.options("/api/v1/uploads")
    assert r.status_code == 204 and r.headers["tus-version"] == "1.0.0"
    assert {"creation", "termination", "checksum", "expiration"} <= set(r.headers["tus-extension"].split(","))
    assert "sha256" in r.headers["tus-checksum-algorithm"]


def test_a_photo_upload_in_two_pieces_stores_the_original_bytes_with_a_verdict(client, auth, enc, services):
    h, data = auth["nurse"], jpeg(scene())
    r = create(client, h, enc, len(data))
    loc = r.headers["location"]
    assert r.headers["upload-offset"] == "0" and "upload-expires" in r.headers
    half = len(data) // 2
    assert send(client, h, loc, data[:half]).status_code == 204
    assert client.head(loc, headers={**h, **TUS}).headers["upload-offset"] == str(half)
    done = send(client, h, loc, data[half:], offset=half)
    assert done.status_code == 204 and done.headers["burnedge-accepted"] == "true"
    status = client.get(loc, headers=h).json()
    asset = status["asset"]
    assert status["state"] == "complete" and asset["sha256"] == hashlib.sha256(data).hexdigest()
    assert (
        asset["media_type"] == "image/jpeg"
        and asset["verdict"]["accepted"]
        and asset["verdict"]["file"] == "IMG_0001.JPG"
    )
    original = client.get(f"/api/v1/assets/{asset['id']}/file", headers=auth["consultant"])
    assert original.content == data
    assert [a["id"] for a in client.get(f"/api/v1/encounters/{enc}/assets", headers=h).json()] == [asset["id"]]


def test_the_same_photo_twice_is_stored_once(client, auth, enc, services):
    data = jpeg(scene(seed=5))
    first, _ = upload(client, auth["nurse"], enc, data)
    second, _ = upload(client, auth["nurse"], enc, data, filename="again.jpg")
    a = client.get(first, headers=auth["nurse"]).json()["asset"]["id"]
    b = client.get(second, headers=auth["nurse"]).json()["asset"]["id"]
    assert a == b and len([f for f in stored_files(services) if f.startswith("blobs/")]) == 1


def test_phone_jpegs_with_data_after_the_image_are_accepted(client, auth, enc):
    # Samsung appends SEF trailers, Pixel "motion photos" a whole MP4, after the JPEG's end marker.
    for trailer in (b"SEFH\x00\x00" + b"\x01" * 300 + b"SEFT", b"\x00\x00\x00\x18ftypmp42" + b"\x00" * 5000):
        _, r = upload(client, auth["clinician"], enc, jpeg(scene(seed=len(trailer))) + trailer)
        assert r.status_code == 204 and r.headers["burnedge-accepted"] == "true"


def test_exif_capture_metadata_is_kept(client, auth, enc):
    loc, _ = upload(client, auth["clinician"], enc, jpeg_with_exif(scene()))
    m = client.get(loc, headers=auth["clinician"]).json()["asset"]["metadata"]
    assert (m["camera_make"], m["camera_model"], m["focal_length_mm"], m["focal_length_35mm"]) == (
        "TestPhone Inc.",
        "Model 7",
        4.25,
        26.0,
    )
    assert m["orientation"] == 6 and m["captured_at"] == "2026:11:22 10:15:00"


def test_heic_photos_and_hevc_and_h264_videos_are_accepted(client, auth, enc, tmp_path):
    h = auth["clinician"]
    loc, r = upload(client, h, enc, heic(scene()), "IMG_0002.HEIC")
    assert r.status_code == 204 and client.get(loc, headers=h).json()["asset"]["media_type"] == "image/heic"
    for codec, name, expected in (("libx265", "clip.MOV", "hevc"), ("libx264", "clip.mp4", "h264")):
        data = video(tmp_path / f"{codec}.mp4", codec)
        loc, r = upload(client, h, enc, data, name)
        assert r.status_code == 204, r.text
        asset = client.get(loc, headers=h).json()["asset"]
        assert asset["kind"] == "video" and asset["metadata"]["video_codec"] == expected
        assert asset["metadata"]["duration_s"] == pytest.approx(2.0, abs=0.1)


@pytest.mark.parametrize(
    "make, status, words",
    [
        (lambda tmp: b"MZ\x90\x00 this is an executable, not a photo" * 50, 415, "neither a photo"),
        (lambda tmp: jpeg(scene())[:-20000], 422, "truncated"),
        (lambda tmp: heic(scene())[:-100], 422, "truncated"),
        (lambda tmp: video(tmp / "v.mp4")[:-4000], 422, "truncated"),
        (lambda tmp: png_bomb(), 422, "refused without decoding"),
    ],
    ids=["not-an-image-named-jpg", "truncated-jpeg", "truncated-heic", "truncated-mp4", "decompression-bomb"],
)
def test_bad_files_are_refused_at_completion_and_nothing_is_kept(
    client, auth, enc, services, tmp_path, make, status, words
):
    loc, r = upload(client, auth["clinician"], enc, make(tmp_path))
    assert r.status_code == status and words in r.json()["detail"]
    assert r.headers["content-type"].startswith("application/problem+json")
    assert stored_files(services) == []
    assert client.get(loc, headers=auth["clinician"]).status_code == 410
    assert client.get(f"/api/v1/encounters/{enc}/assets", headers=auth["clinician"]).json() == []


def test_creation_refuses_what_can_be_refused_up_front(client, auth, enc, services):
    h = auth["clinician"]
    assert create(client, h, enc, 0).status_code == 422
    big = services.config.uploads.max_upload_bytes + 1
    assert create(client, h, enc, big).status_code == 413
    for name in ("../../etc/passwd", "..\\boot.ini", "a/b.jpg", ".."):
        r = create(client, h, enc, 100, filename=name)
        assert r.status_code == 422 and "path" in r.json()["detail"], name
    assert create(client, h, uuid7(), 100).status_code == 404
    no_enc = client.post("/api/v1/uploads", headers={**h, **TUS, "Upload-Length": "100"})
    assert no_enc.status_code == 422 and "encounter_id" in no_enc.json()["detail"]
    assert client.post("/api/v1/uploads", headers={**h, "Upload-Length": "100"}).status_code == 412
    assert create(client, auth["consultant"], enc, 100).status_code == 403
    assert stored_files(services) == []


def test_offset_mismatch_content_type_and_overrun_are_refused(client, auth, enc):
    h, data = auth["clinician"], jpeg(scene())
    loc = create(client, h, enc, len(data)).headers["location"]
    assert send(client, h, loc, data[:1000], offset=500).status_code == 409
    wrong_type = client.patch(
        loc, content=data, headers={**h, **TUS, "Upload-Offset": "0", "Content-Type": "image/jpeg"}
    )
    assert wrong_type.status_code == 415
    assert send(client, h, loc, data + b"extra bytes").status_code == 413
    assert client.head(loc, headers={**h, **TUS}).headers["upload-offset"] == "0"


def test_checksums_are_verified_and_a_bad_chunk_is_discarded(client, auth, enc):
    h, data = auth["clinician"], jpeg(scene())
    loc = create(client, h, enc, len(data)).headers["location"]
    chunk = data[:4096]
    wrong = base64.b64encode(hashlib.sha256(b"something else").digest()).decode()
    bad = send(client, h, loc, chunk, **{"Upload-Checksum": f"sha256 {wrong}"})
    assert bad.status_code == 460
    assert client.head(loc, headers={**h, **TUS}).headers["upload-offset"] == "0"
    good = base64.b64encode(hashlib.sha256(chunk).digest()).decode()
    assert send(client, h, loc, chunk, **{"Upload-Checksum": f"sha256 {good}"}).status_code == 204
    assert send(client, h, loc, data[4096:], offset=4096, **{"Upload-Checksum": "md5 AAAA"}).status_code == 400


def test_termination_and_expiry(client, auth, enc, services):
    h = auth["clinician"]
    loc = create(client, h, enc, 1000).headers["location"]
    send(client, h, loc, b"\xff\xd8\xff" + b"0" * 100)
    assert client.delete(loc, headers={**h, **TUS}).status_code == 204
    assert client.head(loc, headers={**h, **TUS}).status_code == 410
    stale = create(client, h, enc, 1000).headers["location"]
    services.db.connection().execute("UPDATE uploads SET expires_at = '2000-01-01T00:00:00+00:00' WHERE state = 'open'")
    assert client.head(stale, headers={**h, **TUS}).status_code == 410
    assert services.uploads.housekeeping() == (0, 1)
    assert stored_files(services) == []


def test_the_gateway_keeps_serving_while_bad_uploads_fail(client, auth, enc):
    h = auth["clinician"]
    for _ in range(3):
        upload(client, h, enc, os.urandom(5000))
    assert client.get("/health").status_code == 200
    assert client.get(f"/api/v1/encounters/{enc}", headers=h).status_code == 200


def test_an_upload_that_would_fill_the_disk_is_refused_up_front(client, auth, enc, services, monkeypatch):
    import shutil

    real = shutil.disk_usage(services.assets.store.root)
    # Pretend the clinic's disk has 1.5 GiB free: a 1 GiB video would leave less than the 1 GiB reserve.
    monkeypatch.setattr(shutil, "disk_usage", lambda path: real._replace(free=1536 * 1024**2))
    r = create(client, auth["clinician"], enc, 1024**3, "long.mp4")
    assert r.status_code == 507 and "free" in r.json()["detail"]
    assert create(client, auth["clinician"], enc, 100 * 1024**2, "short.mp4").status_code == 201
    # ...and the open 100 MB upload counts against the next one
    assert create(client, auth["clinician"], enc, 450 * 1024**2, "other.mp4").status_code == 507


def test_terminating_an_upload_while_it_receives_is_refused(client, auth, enc, services):
    loc = create(client, auth["clinician"], enc, 1000).headers["location"]
    with services.uploads.claim(loc.rsplit("/", 1)[1]):  # as if a PATCH were streaming right now
        assert client.delete(loc, headers={**auth["clinician"], **TUS}).status_code == 409
        assert services.uploads.housekeeping() == (0, 0)
    assert client.delete(loc, headers={**auth["clinician"], **TUS}).status_code == 204


def test_the_same_bytes_finishing_twice_at_once_make_one_asset(services, enc):
    import threading

    from tests.test_storage import CLINICIAN

    data = jpeg(scene(seed=9))
    parts = []
    for i in range(2):
        part = services.assets.store.parts / f"race-{i}.part"
        part.write_bytes(data)
        parts.append(part)
    barrier, ids = threading.Barrier(2), []

    def finish(part) -> None:
        barrier.wait()
        ids.append(services.assets.store_upload(CLINICIAN, enc, part, "same.jpg").id)

    threads = [threading.Thread(target=finish, args=(p,)) for p in parts]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert len(ids) == 2 and ids[0] == ids[1]
    assert not any(p.exists() for p in parts)


def test_a_full_upload_left_unrecorded_by_a_crash_is_completed_on_head_or_by_housekeeping(client, auth, enc, services):
    h, data = auth["nurse"], jpeg(scene(seed=11))
    for finish_by in ("head", "housekeeping"):
        loc = create(client, h, enc, len(data), f"{finish_by}.jpg").headers["location"]
        # the bytes all reached the disk, then the gateway died before recording the photo
        services.uploads.store.part(loc.rsplit("/", 1)[1]).write_bytes(data)
        if finish_by == "head":
            r = client.head(loc, headers={**h, **TUS})
            assert r.headers["upload-offset"] == str(len(data))
        else:
            assert services.uploads.housekeeping() == (1, 0)
        status = client.get(loc, headers=h).json()
        assert status["state"] == "complete" and status["asset"]["verdict"]["accepted"]
        data = jpeg(scene(seed=12))


def test_nothing_can_touch_an_upload_while_it_completes(client, auth, enc, services):
    h, data = auth["nurse"], jpeg(scene())
    loc = create(client, h, enc, len(data)).headers["location"]
    with services.uploads.claim(loc.rsplit("/", 1)[1]):  # as if its last PATCH were being checked now
        assert send(client, h, loc, b"", offset=0).status_code == 409
        assert client.delete(loc, headers={**h, **TUS}).status_code == 409


def test_an_upload_belongs_to_its_sender_or_their_phone(client, auth, enc, services):
    from harness.processes import login
    from schemas.accounts import Role
    from tests.conftest import make_user

    make_user(services, "nurse.two", Role.nurse)
    other = login(client, "nurse.two")
    loc = create(client, auth["nurse"], enc, 1000).headers["location"]
    assert client.head(loc, headers={**other, **TUS}).status_code == 403
    assert send(client, other, loc, b"\xff\xd8\xff").status_code == 403
    assert client.delete(loc, headers={**other, **TUS}).status_code == 403
    for role in ("consultant", "admin"):
        assert client.head(loc, headers={**auth[role], **TUS}).status_code == 403


def test_tus_client_variants_are_understood(client, auth, enc):
    h, data = auth["nurse"], jpeg(scene(seed=21))
    r = client.post(
        "/api/v1/uploads",
        headers={
            **h,
            **TUS,
            "Upload-Length": str(len(data)),
            "Upload-Metadata": meta(encounter_id=enc, fileName="IMG_7.JPG"),
        },
    )
    loc = r.headers["location"]
    assert loc.startswith("http://") and loc.endswith(r.headers["location"].rsplit("/", 1)[1])
    # a client without PATCH sends POST with X-HTTP-Method-Override (tus-java-client does on old JREs)
    done = client.post(
        loc, content=data, headers={**h, **TUS, **OCTETS, "Upload-Offset": "0", "X-HTTP-Method-Override": "PATCH"}
    )
    assert done.status_code == 204 and done.headers["burnedge-accepted"] == "true"
    assert client.get(loc, headers=h).json()["asset"]["filename"] == "IMG_7.JPG"
    old = client.post("/api/v1/uploads", headers={**h, "Tus-Resumable": "0.2.2", "Upload-Length": "10"})
    assert old.status_code == 412 and old.headers["tus-version"] == "1.0.0" and old.headers["tus-resumable"] == "1.0.0"


def test_a_whole_file_checksum_in_the_metadata_is_checked(client, auth, enc, services):
    h, data = auth["nurse"], jpeg(scene(seed=22))
    good = hashlib.sha256(data).hexdigest()
    for checksum, status in ((f"sha256 {hashlib.sha256(b'other').hexdigest()}", 460), (f"sha256 {good}", 204)):
        r = client.post(
            "/api/v1/uploads",
            headers={
                **h,
                **TUS,
                "Upload-Length": str(len(data)),
                "Upload-Metadata": meta(encounter_id=enc, checksum=checksum),
            },
        )
        assert send(client, h, r.headers["location"], data).status_code == status
    assert len([f for f in stored_files(services) if f.startswith("blobs/")]) == 1


def test_photos_over_the_photo_limit_are_refused(client, auth, enc, services):
    import msgspec

    normal = services.assets.config
    services.assets.config = msgspec.structs.replace(
        normal, uploads=msgspec.structs.replace(normal.uploads, max_photo_bytes=10_000)
    )
    try:
        _, r = upload(client, auth["nurse"], enc, jpeg(scene()))
    finally:
        services.assets.config = normal
    assert r.status_code == 413 and stored_files(services) == []


def test_the_same_photo_for_two_encounters_is_two_assets_one_file(client, auth, enc, services):
    h, data = auth["clinician"], jpeg(scene(seed=23))
    p = patient_body()
    client.post("/api/v1/patients", json=p, headers=h)
    second = encounter_body(p["id"])
    client.post("/api/v1/encounters", json=second, headers=h)
    a, _ = upload(client, h, enc, data)
    b, _ = upload(client, h, second["id"], data)
    ids = {client.get(x, headers=h).json()["asset"]["id"] for x in (a, b)}
    assert len(ids) == 2 and len([f for f in stored_files(services) if f.startswith("blobs/")]) == 1


def test_an_encounter_withdrawn_during_the_upload_leaves_no_file(client, auth, enc, services):
    h, data = auth["clinician"], jpeg(scene(seed=24))
    loc = create(client, h, enc, len(data)).headers["location"]
    client.delete(f"/api/v1/encounters/{enc}", params={"reason": "wrong patient"}, headers={**h, "If-Match": '"1"'})
    r = send(client, h, loc, data)
    assert r.status_code == 422 and "withdrawn" in r.json()["detail"]
    assert [f for f in stored_files(services) if f.startswith("blobs/")] == []
