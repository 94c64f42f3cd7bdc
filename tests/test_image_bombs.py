"""Hostile pictures: what refusing them costs the gateway in time and memory, measured in a fresh process.

Each case runs the two checks an upload's completion runs (check_photo, then the quality gate) in a
child process, and reports the peak resident memory *during* the checks (the kernel's high-water mark,
reset just before) and their time. Measuring in a child keeps this test's own allocations out of it.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from tests.capture_images import jpeg, png_bomb, png_header_bomb, rgb_png, scene

REPO = Path(__file__).resolve().parents[1]
MB = 1024 * 1024

_MEASURE = textwrap.dedent(
    """
    import json, sys, time
    from processing.capture.media import check_photo, sniff
    from processing.capture.quality import gate_bytes
    from schemas.config import QualityGateConfig
    from schemas.errors import InvalidInput

    def status(field):
        for line in open("/proc/self/status"):
            if line.startswith(field):
                return int(line.split()[1]) * 1024

    data = open(sys.argv[1], "rb").read()
    config = QualityGateConfig()
    refused = None
    open("/proc/self/clear_refs", "w").write("5")  # resets VmHWM to the current RSS
    before = status("VmRSS")
    start = time.perf_counter()
    try:
        check_photo(data, sniff(data[:32]), config.max_pixels)
        verdict = gate_bytes(data, config, name="x")
        refused = None if verdict.accepted or verdict.figures else " ".join(verdict.guidance)
    except InvalidInput as exc:
        refused = exc.detail
    elapsed = time.perf_counter() - start
    print(json.dumps({"seconds": elapsed, "peak_growth": status("VmHWM") - before, "refused": refused}))
    """
)


def measure(tmp_path: Path, data: bytes) -> dict:
    picture = tmp_path / "picture"
    picture.write_bytes(data)
    done = subprocess.run(
        [sys.executable, "-c", _MEASURE, str(picture)], capture_output=True, text=True, cwd=REPO, timeout=120
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def normal_photo(tmp_path_factory) -> dict:
    """A 12 MP phone-sized JPEG: the cost every real upload pays."""
    return measure(tmp_path_factory.mktemp("normal"), jpeg(scene(4000, 3000)))


@pytest.mark.skipif(not Path("/proc/self/clear_refs").exists(), reason="needs Linux /proc to measure peak memory")
@pytest.mark.parametrize(
    "make", [png_header_bomb, png_bomb], ids=["370-byte-png-declaring-100000x100000", "40000x40000-valid-png"]
)
def test_a_picture_bomb_is_refused_at_once_with_flat_memory(tmp_path, normal_photo, make):
    bomb = measure(tmp_path, make())
    print(
        f"\nbomb: {bomb['seconds'] * 1000:.1f} ms, +{bomb['peak_growth'] / MB:.1f} MB peak; "
        f"12 MP JPEG: {normal_photo['seconds'] * 1000:.1f} ms, +{normal_photo['peak_growth'] / MB:.1f} MB"
    )
    assert bomb["refused"] and "refused without decoding" in bomb["refused"]
    assert bomb["seconds"] < 0.1
    assert bomb["peak_growth"] < 8 * MB, "refusing a bomb must not allocate in proportion to its declared size"
    assert bomb["peak_growth"] < normal_photo["peak_growth"]


@pytest.mark.skipif(not Path("/proc/self/clear_refs").exists(), reason="needs Linux /proc to measure peak memory")
def test_a_large_png_under_the_limit_is_decoded_in_grey_not_colour(tmp_path, normal_photo):
    width, height = 8000, 6000  # 48 MP, the largest default phone mode, as an RGB PNG (3 bytes a pixel decoded)
    result = measure(tmp_path, rgb_png(width, height))
    print(f"\n48 MP RGB PNG: {result['seconds']:.2f} s, +{result['peak_growth'] / MB:.0f} MB peak")
    assert result["refused"] is None or "larger than" not in result["refused"]
    # libpng converts to grey as it reads (OpenCV holds about two bytes a pixel at its peak); Pillow held the
    # RGB image and its grey copy: four bytes a pixel.
    assert result["peak_growth"] < 2.5 * width * height, "decoded in colour, not straight to grey"


def test_the_pixel_limit_admits_a_48_mp_photo_and_refuses_a_200_mp_one():
    from schemas.config import QualityGateConfig

    limit = QualityGateConfig().max_pixels
    assert 8160 * 6120 <= limit < 16320 * 12240
