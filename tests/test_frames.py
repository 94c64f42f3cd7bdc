"""Frames from video: spread over the clip, the sharpest of each slice, near-duplicates skipped, stored as assets."""

from __future__ import annotations

import hashlib
import json
import os
import re
import subprocess
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

import cv2
import numpy as np
import pytest

import gateway.capture.frames as frames_service
from base.storage import assets as asset_rows
from base.storage import audit, blobs
from base.storage.blobs import MediaStore
from harness.bodies import encounter_body, patient_body
from harness.processes import REPO
from processing.capture import media
from processing.capture.frames import extract
from schemas.config import FramesConfig, QualityGateConfig, UploadConfig
from schemas.errors import InvalidInput
from tests.capture_images import pan_scene, video
from tests.conftest import SHARED
from tests.test_uploads import upload

GATE = QualityGateConfig()


def test_frames_spread_over_the_whole_clip_each_gated(tmp_path):
    path = tmp_path / "pan.mp4"
    video(path, seconds=3.0)
    result = extract(path, FramesConfig(max_frames=6), GATE)
    times = [f.time_s for f in result.frames]
    assert result.decoded == 90 and len(times) == 6
    assert times[0] < 0.5 and times[-1] >= 2.5 and times == sorted(times)  # one pick in each half-second slice
    assert all(f.verdict.accepted for f in result.frames)
    assert all(f.jpeg.startswith(b"\xff\xd8") for f in result.frames)


def test_the_sharpest_frame_of_each_slice_is_chosen(tmp_path):
    path = tmp_path / "shaky.mp4"
    video(path, seconds=2.0, fps=30, blur_except_every=5)  # frames 0, 5, 10, ... are the sharp ones
    result = extract(path, FramesConfig(max_frames=6), GATE)
    frame_numbers = [round(f.time_s * 30) for f in result.frames]
    assert len(frame_numbers) == 6 and all(n % 5 == 0 for n in frame_numbers), frame_numbers
    # (x264 at its default quality softens these frames below the gate's threshold: a fair "blurry")


def test_near_duplicates_from_a_still_camera_are_skipped(tmp_path):
    path = tmp_path / "still.mp4"
    video(path, seconds=2.0, still=True)
    result = extract(path, FramesConfig(max_frames=8), GATE)
    assert len(result.frames) == 1 and len(result.skipped_duplicates) == 7


def test_hevc_video_gives_frames_too(tmp_path):
    path = tmp_path / "clip.mov"
    video(path, codec="libx265", seconds=2.0)
    assert len(extract(path, FramesConfig(max_frames=4), GATE).frames) == 4


def test_10_bit_hdr_video_gives_the_same_frames_as_8_bit(tmp_path):
    # iPhone HDR video is 10-bit HEVC (yuv420p10le): its luma samples are 16-bit words.
    pan = pan_scene((960, 720))
    frames = {}
    for pix_fmt in ("yuv420p", "yuv420p10le"):
        path = tmp_path / f"{pix_fmt}.mov"
        video(path, codec="libx265", seconds=1.0, pix_fmt=pix_fmt, crf=16)
        frames[pix_fmt] = extract(path, FramesConfig(max_frames=3), GATE).frames
        assert len(frames[pix_fmt]) == 3 and all(f.verdict.accepted for f in frames[pix_fmt]), pix_fmt
    for eight, ten in zip(frames["yuv420p"], frames["yuv420p10le"], strict=True):
        assert ten.verdict.figures.mean_intensity == pytest.approx(eight.verdict.figures.mean_intensity, rel=0.15)
        assert ten.verdict.figures.local_sharpness == pytest.approx(eight.verdict.figures.local_sharpness, rel=0.15)
        assert ten.sharpness == pytest.approx(eight.sharpness, rel=0.15)
        x = int(round(ten.time_s * 30) / 29 * 960)  # where the camera was in that frame (30 frames, 960 px pan)
        got = cv2.imdecode(np.frombuffer(ten.jpeg, np.uint8), cv2.IMREAD_COLOR).astype(np.float32)
        assert np.mean(np.abs(got - pan[:, x : x + 960])) < 5  # the colour JPEG is right too


@pytest.mark.parametrize("rotation", [-90, 90, 180])
def test_frames_are_turned_upright_from_the_display_rotation(tmp_path, rotation):
    # The tag is the counter-clockwise turn a player gives the stored picture (np.rot90 counts the same way);
    # an iPhone held upright records landscape pictures tagged -90.
    path = tmp_path / "portrait.mp4"
    video(path, seconds=0.5, still=True, rotation=rotation)
    [frame] = extract(path, FramesConfig(max_frames=1), GATE).frames
    got = cv2.imdecode(np.frombuffer(frame.jpeg, np.uint8), cv2.IMREAD_COLOR).astype(np.float32)
    stored = pan_scene((960, 720))[:, :960]
    upright = np.rot90(stored, rotation // 90)
    assert (
        got.shape == upright.shape and (frame.verdict.figures.width, frame.verdict.figures.height) == got.shape[1::-1]
    )
    assert np.mean(np.abs(got - upright)) < 6
    if rotation % 180:  # turned the other way, the picture is upside down
        assert np.mean(np.abs(got - np.rot90(upright, 2))) > 15
    assert frame.verdict.accepted and frame.verdict.figures.markers  # the gate saw the upright picture too


@pytest.mark.skipif(not (SHARED / "phantoms" / "p2_foot" / "video.mp4").exists(), reason="needs ../shared/phantoms")
def test_cli_frames_on_the_phantom_orbit_video(tmp_path):
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "burnedge.cli",
            "frames",
            str(SHARED / "phantoms" / "p2_foot" / "video.mp4"),
            "--out",
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        cwd=REPO,
    )
    assert r.returncode == 0, r.stderr
    listing = json.loads((tmp_path / "frames.json").read_text())
    assert len(listing["frames"]) == 15 and listing["decoded"] == 300
    assert all((tmp_path / f["file"]).exists() and f["verdict"]["accepted"] for f in listing["frames"])
    assert all(f["verdict"]["figures"]["markers"] for f in listing["frames"])


def test_an_uploaded_video_becomes_frames_linked_to_it(client, auth, services, tmp_path):
    h = auth["clinician"]
    enc = _encounter(client, h)
    loc, r = upload(client, h, enc, video(tmp_path / "v.mp4", seconds=3.0), "orbit.mp4")
    assert r.status_code == 204, r.text
    video_id = r.headers["burnedge-asset-id"]
    services.frames.extract_pending()  # races with the scheduler's run, brought forward by the upload
    assets = client.get(f"/api/v1/encounters/{enc}/assets", headers=h).json()
    frames = [a for a in assets if a["kind"] == "frame"]
    assert len(frames) == services.config.frames.max_frames
    assert len({f["id"] for f in frames}) == len({f["sha256"] for f in frames}) == len(frames)  # each once
    assert all(f["source_asset_id"] == video_id and f["verdict"] is not None for f in frames)
    assert services.frames.pending() == [] and services.frames.extract_one(video_id) == []
    assert len(client.get(f"/api/v1/encounters/{enc}/assets", headers=h).json()) == len(assets)
    readiness = client.get(f"/api/v1/encounters/{enc}/capture-readiness", headers=h).json()
    assert readiness["views"] == len(frames) and readiness["accepted_views"] >= 6


def _encounter(client, headers) -> str:
    p = patient_body()
    client.post("/api/v1/patients", json=p, headers=headers)
    e = encounter_body(p["id"])
    client.post("/api/v1/encounters", json=e, headers=headers)
    return e["id"]


def _frame_rows(services, video_id: str) -> list:
    return services.db.connection().execute("SELECT * FROM assets WHERE source_asset_id = ?", (video_id,)).fetchall()


def test_a_video_the_extractor_fails_on_does_not_stop_the_others(client, auth, services, tmp_path, monkeypatch):
    client.app.state.scheduler.pause()  # this test runs the extraction itself
    h = auth["clinician"]
    enc = _encounter(client, h)
    first = video(tmp_path / "first.mp4", seconds=1.0)
    broken = services.assets.store.blob(hashlib.sha256(first).hexdigest())
    real = frames_service.extract

    def extract_or_crash(path, *args, **kwargs):
        if path == broken:
            raise RuntimeError("cv2.error in a 4096x2 video")  # not a BurnedgeError
        return real(path, *args, **kwargs)

    monkeypatch.setattr(frames_service, "extract", extract_or_crash)
    ids = [
        upload(client, h, enc, data, name)[1].headers["burnedge-asset-id"]
        for data, name in ((first, "first.mp4"), (video(tmp_path / "second.mp4", seconds=1.5), "second.mp4"))
    ]
    assert services.frames.extract_pending() == 2
    assert len(_frame_rows(services, ids[1])) > 0  # the second video got its frames all the same
    # One more try at the next run (the failure may have been the gateway stopping), then no more.
    assert services.frames.pending() == [ids[0]] and services.frames.extract_pending() == 1
    first = asset_rows.find_frames_progress(services.db.connection(), ids[0])
    assert first.done_at and "RuntimeError" in first.error and _frame_rows(services, ids[0]) == []
    assert services.frames.pending() == [] and services.frames.extract_pending() == 0


def test_a_video_s_frames_are_stored_all_together_or_not_at_all(client, auth, services, tmp_path, monkeypatch):
    client.app.state.scheduler.pause()
    h = auth["clinician"]
    enc = _encounter(client, h)
    video_id = upload(client, h, enc, video(tmp_path / "v.mp4", seconds=2.0), "v.mp4")[1].headers["burnedge-asset-id"]
    real, calls = audit.append, []

    def append_or_fail(conn, **fields):
        calls.append(fields["action"])
        if calls.count("asset.create") == 3:
            raise OSError("disk full")  # in the middle of storing the frames
        return real(conn, **fields)

    monkeypatch.setattr(audit, "append", append_or_fail)
    assert services.frames.extract_pending() == 0
    assert _frame_rows(services, video_id) == [] and services.frames.pending() == [video_id]
    monkeypatch.setattr(audit, "append", real)
    stored = services.frames.extract_one(video_id)
    assert len(stored) == services.config.frames.max_frames == len(_frame_rows(services, video_id))
    assert services.frames.pending() == [] and services.frames.extract_one(video_id) == []
    assert len(_frame_rows(services, video_id)) == len(stored)
    assert all(services.assets.store.blob(f.sha256).exists() for f in stored)
    assert audit.verify(services.db.connection()).ok  # the rolled-back entries left no gap


def test_two_writers_of_the_same_frame_do_not_clash(tmp_path, monkeypatch):
    store = MediaStore(tmp_path)
    data = b"\xff\xd8" + bytes(range(256)) * 4000
    together = threading.Barrier(2, timeout=10)
    waited, real_fsync = set(), os.fsync

    def fsync_once_together(fd):
        # Both writers have written their temporary file before either renames it.
        if threading.get_ident() not in waited:
            waited.add(threading.get_ident())
            together.wait()
        real_fsync(fd)

    monkeypatch.setattr(blobs.os, "fsync", fsync_once_together)
    with ThreadPoolExecutor(2) as pool:
        results = [f.result() for f in [pool.submit(store.put, data) for _ in range(2)]]
    assert results[0] == results[1] and results[0][1].read_bytes() == data
    assert sorted(p.name for p in results[0][1].parent.iterdir()) == [results[0][0]]  # no temporary file left


@pytest.mark.parametrize(
    "size, seconds, limits, words",
    [
        ((64, 64), 0.5, GATE, "720p"),
        ((640, 480), 0.5, GATE, "720p"),
        ((960, 720), 0.5, QualityGateConfig(min_width=1280, min_height=720), "(1280x720): record at 720p"),
        ((4112, 608), 0.2, GATE, "more than 4096 on a side"),
        ((960, 720), 2.0, GATE, "longer than the 1.5 s allowed"),
    ],
    ids=["tiny", "vga", "below-configured-minimum", "too-wide", "too-long"],
)
def test_check_video_refuses_clips_too_small_too_large_or_too_long(tmp_path, size, seconds, limits, words):
    path = tmp_path / "clip.mp4"
    video(path, seconds=seconds, size=size)
    with pytest.raises(InvalidInput, match=re.escape(words)):
        media.check_video(path, limits=limits, max_seconds=1.5)


def test_check_video_accepts_a_phone_clip_and_its_default_limits_are_the_photo_gates(tmp_path):
    path = tmp_path / "clip.mp4"
    video(path, seconds=1.0, size=(800, 600))
    meta = media.check_video(path)
    assert (meta.width, meta.height, meta.video_codec) == (800, 600, "h264")
    assert UploadConfig().max_video_seconds == 600 and media.MAX_VIDEO_SIDE == 4096
