"""Files of bundles stored before the center kept them sealed (center/sealed_bundles.py): plain files named by their
sha256 under store_dir/parts, read back as they are. Nothing new is written here."""

from __future__ import annotations

from pathlib import Path

from schemas.errors import NotFound


class PartStore:
    def __init__(self, root: Path):
        self.root = root

    def path(self, sha256: str) -> Path:
        return self.root / sha256[:2] / sha256

    def read(self, sha256: str) -> bytes:
        try:
            return self.path(sha256).read_bytes()
        except FileNotFoundError as exc:
            raise NotFound(f"the stored file {sha256[:12]}... is missing from the center's store") from exc
