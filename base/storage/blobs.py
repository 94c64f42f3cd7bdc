"""Media files on disk: uploads in progress, and finished files stored by their SHA-256.

Finished files keep their original bytes (medico-legal) under blobs/ab/abcdef…, so the
same photo uploaded twice is stored once. Moves are renames within one folder tree, so a
file is either fully in place or not there at all.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from base.storage.durable import fsync_dir, replace_atomically

CHUNK = 1024 * 1024


class MediaStore:
    def __init__(self, root: str | Path):
        self.root = Path(root)
        self.parts = self.root / "uploads"
        self.blobs = self.root / "blobs"
        self.parts.mkdir(parents=True, exist_ok=True)
        self.blobs.mkdir(parents=True, exist_ok=True)

    def part(self, upload_id: str) -> Path:
        return self.parts / f"{upload_id}.part"

    def blob(self, sha256: str) -> Path:
        return self.blobs / sha256[:2] / sha256

    def create_part(self, upload_id: str) -> Path:
        path = self.part(upload_id)
        path.touch(exist_ok=False)
        return path

    def promote(self, part: Path, sha256: str) -> Path:
        """Move a finished upload into the blob store; if the same bytes are there already, keep those."""
        final = self.blob(sha256)
        if final.exists():
            part.unlink()
            return final
        final.parent.mkdir(exist_ok=True)
        with open(part, "rb") as f:
            os.fsync(f.fileno())
        os.replace(part, final)
        fsync_dir(final.parent)
        return final

    def put(self, data: bytes) -> tuple[str, Path]:
        """Store bytes made by the gateway itself (video frames); returns their SHA-256 and path.

        Written under a temporary name of its own, then renamed: two writers of the same bytes
        never share a file, and the last rename leaves the same content in place.
        """
        sha = hashlib.sha256(data).hexdigest()
        final = self.blob(sha)
        if not final.exists():
            final.parent.mkdir(exist_ok=True)
            replace_atomically(final, data)
        return sha, final


def sha256_of(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        while chunk := f.read(CHUNK):
            digest.update(chunk)
    return digest.hexdigest()
