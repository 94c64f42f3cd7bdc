"""Writing stage artifacts so that a crash never leaves a half-written one that looks finished."""

from __future__ import annotations

import json
import logging
import os
import shutil
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import msgspec

from schemas.reconstruction import StageTiming

log = logging.getLogger(__name__)

T = TypeVar("T")


def write_json(path: Path, value: object) -> Path:
    """Write `value` as indented JSON via a temporary file and an atomic rename."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_bytes(msgspec.json.format(msgspec.json.encode(value), indent=2))
    with open(tmp, "rb") as handle:
        os.fsync(handle.fileno())
    os.replace(tmp, path)
    return path


def read_json(path: Path, kind: type[T]) -> T:
    return msgspec.json.decode(path.read_bytes(), type=kind)


def fresh_dir(path: Path) -> Path:
    """An empty directory at `path` (whatever an interrupted run left there is removed)."""
    if path.exists():
        shutil.rmtree(path)
    path.mkdir(parents=True)
    return path


def publish_dir(tmp: Path, final: Path) -> Path:
    """Move a finished temporary directory into place, replacing an older one."""
    if final.exists():
        shutil.rmtree(final)
    os.replace(tmp, final)
    return final


class Stages:
    """Resumable stages in one analysis folder.

    A stage whose done-artifact exists and whose fingerprint (a hash of what it was built from) is unchanged is
    skipped. A stage that runs first removes its own and every later stage's done-artifact and fingerprint, so
    nothing stale outlives its rerun; its fingerprint is stored only once it has finished.
    """

    def __init__(self, fingerprints_file: Path, done: dict[str, Path], wanted: dict[str, str]):
        self.file, self.done, self.wanted = fingerprints_file, done, wanted
        self.order = list(done)
        self.stored = json.loads(fingerprints_file.read_text()) if fingerprints_file.exists() else {}
        self.timings: list[StageTiming] = []

    def run(self, name: str, work: Callable[[], object]) -> None:
        if self.done[name].exists() and self.stored.get(name) == self.wanted[name]:
            self.timings.append(StageTiming(stage=name, seconds=0.0, resumed=True))
            return
        for later in self.order[self.order.index(name) :]:
            self.done[later].unlink(missing_ok=True)
            self.stored.pop(later, None)
        write_json(self.file, self.stored)
        self.done[name].parent.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        work()
        self.stored[name] = self.wanted[name]
        write_json(self.file, self.stored)
        self.timings.append(StageTiming(stage=name, seconds=round(time.perf_counter() - start, 2)))
        log.info("stage %s done in %.1f s", name, self.timings[-1].seconds)
