"""Received bundles kept at rest as the clinic sealed them: its encrypted chunks, under `store_dir/bundles/`.

Nothing is decrypted to disk. A file of a case is read by opening the bundle's key with the center's private key
(keys_dir, kept apart from the database and the store) and decrypting only the chunks that hold the file, one at a
time: a copied database or store folder alone reveals no photo or record, and memory stays bounded by the chunk
size whatever the case's size. Each chunk stays authenticated (XChaCha20-Poly1305, bound to its bundle, index and
count), so a chunk altered on disk is refused rather than served.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path

from nacl.public import PrivateKey

from base.storage.durable import fsync_dir
from schemas.central import StoredPart
from schemas.errors import NotFound, StorageError, TransferRejected
from sync.sealing import OVERHEAD, open_chunks, unseal_key


def chunk_name(index: int) -> str:
    return f"{index:06d}.chunk"


class SealedBundles:
    def __init__(self, root: Path, box: PrivateKey):
        self.root = root
        self.box = box

    def folder(self, site_id: str, bundle_id: str) -> Path:
        return self.root / site_id / bundle_id

    def keep(self, staged: Path, site_id: str, bundle_id: str, count: int) -> None:
        """Make the staged chunks the bundle's at rest, durably, before the row that names them is committed.
        Hard links, not a rename: another worker may be committing the same bundle from the same staged files."""
        final = self.folder(site_id, bundle_id)
        final.mkdir(parents=True, exist_ok=True)
        for index in range(count):
            target = final / chunk_name(index)
            try:
                os.link(staged / chunk_name(index), target)
            except FileExistsError:
                pass  # the same verified chunk, linked by another worker
            with open(target, "rb") as f:
                os.fsync(f.fileno())
        fsync_dir(final)
        fsync_dir(final.parent)
        fsync_dir(self.root)

    def forget(self, site_id: str, bundle_id: str) -> None:
        """Remove a bundle's chunks that no stored row names (its commit failed)."""
        shutil.rmtree(self.folder(site_id, bundle_id), ignore_errors=True)

    def read(self, site_id: str, bundle_id: str, part: StoredPart) -> Iterator[bytes]:
        """The file's bytes, decrypted a chunk at a time."""
        folder = self.folder(site_id, bundle_id)
        key = unseal_key(part.sealed_key, self.box)
        plain_size = _plain_chunk_size(folder, part.chunks)
        first = part.plain_offset // plain_size
        last = (part.plain_offset + part.size - 1) // plain_size if part.size else first - 1
        start = part.plain_offset - first * plain_size
        left = part.size
        try:
            for plain in _open_range(key, bundle_id, folder, first, last, part.chunks):
                piece = plain[start : start + left]
                start = 0
                left -= len(piece)
                yield piece
        except TransferRejected as exc:
            raise StorageError(f"the stored file {part.name} of bundle {bundle_id} is damaged: {exc.detail}") from exc
        if left:
            raise StorageError(f"the stored file {part.name} of bundle {bundle_id} ends early")


def _plain_chunk_size(folder: Path, count: int) -> int:
    """Every chunk but the last holds the same plaintext size: the first one's, less its nonce and tag."""
    try:
        return (folder / chunk_name(0)).stat().st_size - OVERHEAD if count > 1 else 1 << 62
    except FileNotFoundError as exc:
        raise NotFound(f"the stored chunks of bundle {folder.name} are missing from the center's store") from exc


def _open_range(key: bytes, bundle_id: str, folder: Path, first: int, last: int, count: int) -> Iterator[bytes]:
    return open_chunks(key, bundle_id, (_chunk(folder, bundle_id, i) for i in range(first, last + 1)), count, first)


def _chunk(folder: Path, bundle_id: str, index: int) -> bytes:
    try:
        return (folder / chunk_name(index)).read_bytes()
    except FileNotFoundError as exc:
        raise NotFound(f"chunk {index} of bundle {bundle_id} is missing from the center's store") from exc
