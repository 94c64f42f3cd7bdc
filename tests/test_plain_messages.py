"""Messages a person reads name the problem in words: no "<_io.BytesIO object at 0x...>", no "[Errno 1094995529]",
no traceback, whatever file is fed to the CLI or the API (issue 16, plain messages)."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest

from harness.processes import REPO
from schemas.errors import plain
from tests.test_uploads import enc, upload  # noqa: F401 (enc is a fixture)

INTERNALS = re.compile(r"object at 0x|Errno|Traceback|File \"")
NOT_AN_IMAGE = b"These are the clinic's opening hours, not a photo.\n" * 20
# Bytes that start like a file of that type, so they get past the type check to the decoders.
FAKE_MP4 = b"\x00\x00\x00\x18ftypmp42\x00\x00\x00\x00mp42isom" + b"\x00garbage" * 500
FAKE_PNG = b"\x89PNG\r\n\x1a\n" + b"\x00not really a png" * 200
FAKE_JPEG = b"\xff\xd8\xff\xe0" + b"\x13junk" * 500


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "burnedge.cli", *args], capture_output=True, text=True, cwd=REPO, timeout=120
    )


@pytest.mark.parametrize(
    "name, data",
    [
        ("notes.jpg", NOT_AN_IMAGE),
        ("empty.jpg", b""),
        ("fake.png", FAKE_PNG),
        ("fake.jpg", FAKE_JPEG),
        ("clip.mp4", NOT_AN_IMAGE),
    ],
)
def test_the_gate_command_explains_unreadable_files_in_words(tmp_path, name, data):
    path = tmp_path / name
    path.write_bytes(data)
    r = _cli("gate", str(path))
    assert r.returncode == 0, r.stderr
    (verdict,) = json.loads(r.stdout)
    assert not verdict["accepted"] and verdict["file"].endswith(name)
    text = " ".join(verdict["guidance"])
    assert "not a photo" in text or "truncated" in text or "no pixels" in text, text
    assert not INTERNALS.search(text), text


@pytest.mark.parametrize("name, data", [("notes.mp4", NOT_AN_IMAGE), ("fake.mp4", FAKE_MP4), ("empty.mov", b"")])
def test_the_frames_command_refuses_non_videos_in_words(tmp_path, name, data):
    path = tmp_path / name
    path.write_bytes(data)
    r = _cli("frames", str(path), "--out", str(tmp_path / "out"))
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert not INTERNALS.search(r.stderr), r.stderr
    assert "video" in r.stderr


@pytest.mark.parametrize(
    "data, status",
    [(NOT_AN_IMAGE, 415), (FAKE_PNG, 422), (FAKE_JPEG, 422), (FAKE_MP4, 422)],
    ids=["text", "png-header-then-garbage", "jpeg-header-then-garbage", "mp4-header-then-garbage"],
)
def test_uploads_of_non_media_are_refused_in_words(client, auth, enc, data, status):  # noqa: F811
    _, r = upload(client, auth["clinician"], enc, data)
    assert r.status_code == status, r.text
    detail = r.json()["detail"]
    assert not INTERNALS.search(detail), detail


def test_plain_strips_object_reprs_and_errno_codes():
    exc = OSError("cannot identify image file <_io.BytesIO object at 0x7f3a2c1b9e40>")
    assert plain(exc) == "cannot identify image file"
    assert plain(OSError("[Errno 1094995529] Invalid data found when processing input: 'x.mp4'")) == (
        "Invalid data found when processing input: 'x.mp4'"
    )
    assert plain(ValueError("")) == "ValueError"
