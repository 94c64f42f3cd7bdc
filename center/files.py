"""The center's content-addressed store of bundle parts: written under a temporary name, synced, then renamed."""

from __future__ import annotations

import hashlib
from pathlib import Path

from base.storage.durable import replace_atomically
from schemas.errors import NotFound


class PartStore:
    def __init__(self, root: Path):
        self.root = root
        self.root.mkdir(parents=True, exist_ok=True)

    def path(self, sha256: str) -> Path:
        return self.root / sha256[:2] / sha256

    def put(self, sha256: str, data: bytes) -> Path:
        final = self.path(sha256)
        if final.exists():  # the same bytes from another bundle or version
            return final
        if hashlib.sha256(data).hexdigest() != sha256:
            raise ValueError("part bytes do not match their sha256")
        final.parent.mkdir(exist_ok=True)
        replace_atomically(final, data)
        return final

    def read(self, sha256: str) -> bytes:
        try:
            return self.path(sha256).read_bytes()
        except FileNotFoundError as exc:
            raise NotFound(f"the stored file {sha256[:12]}... is missing from the center's store") from exc
