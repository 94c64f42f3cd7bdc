"""Rendered phantoms shared within one test run.

The phantom generator is deterministic (tests/test_phantom.py: the same seed gives the same files), so the tests and
fixtures that start from the same spec copy the run's first render of it instead of rendering it again (about 13 s
each on two cores). The copies are theirs to change; the renders go when the run ends.
"""

from __future__ import annotations

import atexit
import functools
import hashlib
import shutil
import tempfile
from pathlib import Path

import msgspec

from schemas.phantom import PhantomSpec


@functools.cache
def _renders() -> Path:
    folder = Path(tempfile.mkdtemp(prefix="burnedge-phantoms-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


def rendered(spec: PhantomSpec, out: Path) -> Path:
    """`out` holding the phantom `spec` describes (rendered once per run); `out`."""
    from processing.phantom.generate import run as render_phantom  # native libraries: only where used

    key = hashlib.sha256(msgspec.json.encode(spec)).hexdigest()[:20]
    kept = _renders() / key
    if not kept.exists():
        partial = _renders() / f"{key}.partial"
        shutil.rmtree(partial, ignore_errors=True)
        render_phantom(spec, partial)
        partial.rename(kept)
    shutil.copytree(kept, out, dirs_exist_ok=True)
    return out
