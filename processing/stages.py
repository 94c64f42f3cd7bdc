"""The stage plumbing every pipeline shares (reconstruction, analysis, segmentation, tracking): artifacts written so
that a crash never leaves a half-written one that looks finished, stages that resume, and the code digest."""

from __future__ import annotations

import ast
import functools
import hashlib
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


PIPELINES = ("processing.analysis.pipeline", "processing.reconstruction.pipeline")
"""Where the analysis code starts: the code digest covers every project module these import, transitively."""
PROJECT = ("processing", "schemas")
"""The packages whose modules count (third-party code is pinned by the install, not hashed here)."""


def _module_file(root: Path, name: str) -> Path | None:
    base = root.joinpath(*name.split("."))
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _imports(path: Path, name: str) -> set[str]:
    """Every module name `path` imports (absolute and relative, inside functions too), and its parents."""
    found = set()
    for node in ast.walk(ast.parse(path.read_bytes(), str(path))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            package = name if path.name == "__init__.py" else name.rpartition(".")[0]
            for _ in range(node.level - 1):
                package = package.rpartition(".")[0]
            prefix = ".".join(p for p in (package if node.level else "", node.module or "") if p)
            found.add(prefix)
            found.update(f"{prefix}.{alias.name}" for alias in node.names)
    return {".".join(n.split(".")[:k]) for n in found for k in range(1, n.count(".") + 2)}


def code_files(roots: tuple[str, ...] = PIPELINES) -> list[Path]:
    """The project's source files that `roots` import, found by walking the imports (no hand-kept list)."""
    root = Path(__file__).resolve().parents[1]
    seen: dict[str, Path] = {}
    todo = list(roots)
    while todo:
        name = todo.pop()
        if name in seen or name.split(".")[0] not in PROJECT:
            continue
        path = _module_file(root, name)
        if path is None:
            continue
        seen[name] = path
        todo.extend(_imports(path, name) - seen.keys())
    return sorted(seen.values())


@functools.cache
def code_digest() -> str:
    """Hash of the science and schema code an analysis runs: a stage made by other code is rerun, never reused
    (a resumed job after an upgrade must not read artifacts the new code would not have written)."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for path in code_files():
        digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


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


SECONDS = "_seconds"
"""The fingerprints file's entry for the stages' durations (no stage has this name)."""


class Stages:
    """Resumable stages in one analysis folder.

    A stage whose done-artifact exists and whose fingerprint (a hash of what it was built from) is unchanged is
    skipped. A stage that runs first removes its own and every later stage's done-artifact and fingerprint, so
    nothing stale outlives its rerun; its fingerprint is stored only once it has finished.
    """

    def __init__(
        self,
        fingerprints_file: Path,
        done: dict[str, Path],
        wanted: dict[str, str],
        on_start: Callable[[str], None] | None = None,
    ):
        """`on_start(name)` is told of each stage as it begins (or is found finished): progress for a waiting user."""
        self.file, self.done, self.wanted, self.on_start = fingerprints_file, done, wanted, on_start
        self.order = list(done)
        self.stored = json.loads(fingerprints_file.read_text()) if fingerprints_file.exists() else {}
        self.seconds: dict[str, float] = self.stored.pop(SECONDS, {})
        """How long each finished stage took when it was made (kept with the fingerprints)."""
        self.timings: list[StageTiming] = []

    def run(self, name: str, work: Callable[[], object]) -> None:
        if self.on_start is not None:
            self.on_start(name)
        if self.done[name].exists() and self.stored.get(name) == self.wanted[name]:
            self.timings.append(StageTiming(stage=name, seconds=self.seconds.get(name, 0.0), resumed=True))
            return
        for later in self.order[self.order.index(name) :]:
            self.done[later].unlink(missing_ok=True)
            self.stored.pop(later, None)
            self.seconds.pop(later, None)
        self._save()
        self.done[name].parent.mkdir(parents=True, exist_ok=True)
        start = time.perf_counter()
        work()
        self.stored[name] = self.wanted[name]
        self.seconds[name] = round(time.perf_counter() - start, 2)
        self._save()
        self.timings.append(StageTiming(stage=name, seconds=self.seconds[name]))
        log.info("stage %s done in %.1f s", name, self.timings[-1].seconds)

    def _save(self) -> None:
        write_json(self.file, {**self.stored, SECONDS: self.seconds})
