"""Writing files so that a power cut leaves the old content or the new, never part of either."""

from __future__ import annotations

import os
import uuid
from pathlib import Path


def fsync_dir(path: Path) -> None:
    """Make the names in a folder (files created, renamed or removed there) survive a power cut."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def write_file(path: Path, data: bytes, *, exclusive: bool = False) -> None:
    """Write and fsync `data` to `path` itself (`exclusive`: refuse an existing file)."""
    with open(path, "xb" if exclusive else "wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())


def replace_atomically(path: Path, data: bytes) -> None:
    """Write under a temporary name of this writer's own, then rename over `path` and sync its folder; two writers
    never share a temporary file, and the last rename wins whole."""
    tmp = path.with_name(f"{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        write_file(tmp, data, exclusive=True)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    fsync_dir(path.parent)
