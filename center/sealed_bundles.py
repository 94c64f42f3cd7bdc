"""Received bundles kept at rest as the clinic sealed them: its encrypted chunks one after the other, in one file per
bundle under `store_dir/bundles/{site}/{bundle}/sealed.bin`.

Nothing is decrypted to disk. A file of a case is read by opening the bundle's key with the center's private key
(keys_dir, kept apart from the database and the store) and decrypting only the chunks that hold the file, one at a
time: a copied database or store folder alone reveals no photo or record, and memory stays bounded by the chunk
size whatever the case's size. Each chunk stays authenticated (XChaCha20-Poly1305, bound to its bundle, index and
count), so a chunk altered on disk is refused rather than served.
"""

from __future__ import annotations

import os
import shutil
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

from nacl.public import PrivateKey

from base.storage.durable import fsync_dir
from schemas.central import StoredPart
from schemas.errors import NotFound, StorageError, TransferRejected
from sync.sealing import OVERHEAD, open_chunks, unseal_key

SEALED_FILE = "sealed.bin"


def chunk_name(index: int) -> str:
    """A chunk's file while its bundle is being received (store_dir/incoming/{site}/{bundle}/)."""
    return f"{index:06d}.chunk"


class SealedWriter:
    """The chunks of one bundle written out as they are verified, kept only by `close_durably()`: under a name of
    this writer's own until then, so two workers committing the same bundle never share a half-written file."""

    def __init__(self, final: Path):
        self.final = final
        final.parent.mkdir(parents=True, exist_ok=True)
        self._tmp = final.with_name(f"{final.name}.{uuid.uuid4().hex}.tmp")
        self._file = open(self._tmp, "xb")  # closed by close_durably or discard

    def write(self, ciphertext: bytes) -> None:
        self._file.write(ciphertext)

    def close_durably(self) -> None:
        """On disk whole, before the row that names it is committed: one fsync for the whole bundle."""
        self._file.flush()
        os.fsync(self._file.fileno())
        self._file.close()
        os.replace(self._tmp, self.final)  # the same verified bytes whichever worker renames last
        for folder in (self.final.parent, self.final.parent.parent, self.final.parent.parent.parent):
            fsync_dir(folder)

    def discard(self) -> None:
        self._file.close()
        self._tmp.unlink(missing_ok=True)


class SealedBundles:
    def __init__(self, root: Path, box: PrivateKey):
        self.root = root
        self.box = box

    def folder(self, site_id: str, bundle_id: str) -> Path:
        return self.root / site_id / bundle_id

    def writer(self, site_id: str, bundle_id: str) -> SealedWriter:
        return SealedWriter(self.folder(site_id, bundle_id) / SEALED_FILE)

    def forget(self, site_id: str, bundle_id: str) -> None:
        """Remove a bundle's file that no stored row names (its commit failed)."""
        shutil.rmtree(self.folder(site_id, bundle_id), ignore_errors=True)

    def sweep_unfinished(self, older_than_s: float) -> int:
        """Remove files a worker was writing when it was killed (kept under its own temporary name, never read);
        how many."""
        cutoff = time.time() - older_than_s
        left = [p for p in self.root.glob(f"*/*/{SEALED_FILE}.*.tmp") if p.stat().st_mtime < cutoff]
        for path in left:
            path.unlink(missing_ok=True)
        return len(left)

    def read(self, site_id: str, bundle_id: str, part: StoredPart) -> Iterator[bytes]:
        """The file's bytes, decrypted a chunk at a time."""
        path = self.folder(site_id, bundle_id) / SEALED_FILE
        key = unseal_key(part.sealed_key, self.box)
        plain_size = part.chunk_bytes - OVERHEAD if part.chunks > 1 else 1 << 62
        first = part.plain_offset // plain_size
        last = (part.plain_offset + part.size - 1) // plain_size if part.size else first - 1
        start, left = part.plain_offset - first * plain_size, part.size
        try:
            with open(path, "rb") as sealed:
                for plain in open_chunks(key, bundle_id, _chunks(sealed, part, first, last), part.chunks, first):
                    piece = plain[start : start + left]
                    start, left = 0, left - len(piece)
                    yield piece
        except FileNotFoundError as exc:
            raise NotFound(f"bundle {bundle_id} is missing from the center's store") from exc
        except TransferRejected as exc:
            raise StorageError(f"the stored file {part.name} of bundle {bundle_id} is damaged: {exc.detail}") from exc
        if left:
            raise StorageError(f"the stored file {part.name} of bundle {bundle_id} ends early")


def _chunks(sealed, part: StoredPart, first: int, last: int) -> Iterator[bytes]:
    sealed.seek(first * part.chunk_bytes)
    for _ in range(first, last + 1):
        yield sealed.read(part.chunk_bytes)  # the last chunk reads short, to the end of the file
