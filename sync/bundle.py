"""Case bundles: a self-contained snapshot of one encounter, and the container that carries it.

Container layout (what is encrypted): b"BEB1", the manifest's length (8 bytes, big-endian), the manifest as JSON,
then every part's bytes in the manifest's order. Each part is listed with its sha256 and size; the center checks
all of them (ContainerCheck, as the chunks are decrypted) before it stores the bundle.
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass
from functools import cached_property
from pathlib import PurePosixPath

import msgspec

from schemas.errors import TransferRejected
from schemas.transfer import BundleManifest, BundlePart

MAGIC = b"BEB1"
_LENGTH = struct.Struct(">Q")
MAX_MANIFEST_BYTES = 4 * 1024 * 1024

MEDIA_TYPES = {
    ".json": "application/json",
    ".glb": "model/gltf-binary",
    ".jpg": "image/jpeg",
    ".jpeg": "image/jpeg",
    ".png": "image/png",
    ".pdf": "application/pdf",
    ".heic": "image/heic",
    ".ply": "application/octet-stream",
}


@dataclass(frozen=True)
class PartData:
    name: str
    data: bytes

    @cached_property
    def described(self) -> BundlePart:
        """Computed once: the outbox's change check and the manifest both need every part's sha256."""
        suffix = PurePosixPath(self.name).suffix.lower()
        return BundlePart(
            name=self.name,
            media_type=MEDIA_TYPES.get(suffix, "application/octet-stream"),
            sha256=hashlib.sha256(self.data).hexdigest(),
            size=len(self.data),
        )


def pack(manifest: BundleManifest, parts: list[PartData]) -> bytes:
    """The container's bytes; the manifest's part list must describe `parts` in order."""
    _, pieces = packed(manifest, parts)
    return b"".join(pieces)


def packed(manifest: BundleManifest, parts: list[PartData]) -> tuple[int, list[bytes]]:
    """The container's size and its pieces in order (the head, then each part's bytes), not joined."""
    if [p.name for p in manifest.parts] != [p.name for p in parts]:
        raise ValueError("the manifest must list the parts in the order they are packed")
    head = msgspec.json.encode(manifest)
    pieces = [MAGIC + _LENGTH.pack(len(head)) + head, *(p.data for p in parts)]
    return sum(len(piece) for piece in pieces), pieces


def check_part_name(name: str) -> None:
    path = PurePosixPath(name)
    if not name or path.is_absolute() or ".." in path.parts or "\\" in name or len(name) > 300:
        raise TransferRejected(f"part name {name!r} is not a safe relative path", code="bad-bundle")


class ContainerCheck:
    """A container checked as it is fed in pieces, holding no more than the manifest and one piece: the magic, the
    manifest, then each part's size and sha256 against it. `finish()` gives the manifest and where the first part
    starts; TransferRejected as soon as anything does not match."""

    def __init__(self):
        self._head = bytearray()
        self.manifest: BundleManifest | None = None
        self.parts_offset = 0
        self._index = 0
        self._left = 0
        self._hash = hashlib.sha256()

    def feed(self, data: bytes) -> None:
        view = memoryview(data)
        if self.manifest is None:
            view = self._read_head(view)
        while len(view):
            if self._index >= len(self.manifest.parts):
                raise TransferRejected("the bundle has bytes beyond its listed parts", code="bad-bundle")
            take = min(self._left, len(view))
            self._hash.update(view[:take])
            self._left -= take
            view = view[take:]
            self._close_finished_parts()

    def finish(self) -> tuple[BundleManifest, int]:
        if self.manifest is None or self._index < len(self.manifest.parts):
            raise TransferRejected("the bundle ends before its listed parts do", code="bad-bundle")
        return self.manifest, self.parts_offset

    def _read_head(self, view: memoryview) -> memoryview:
        need = 12 if len(self._head) < 12 else 12 + _LENGTH.unpack_from(self._head, 4)[0]
        while len(self._head) < need and len(view):
            take = min(need - len(self._head), len(view))
            self._head += view[:take]
            view = view[take:]
            if len(self._head) == 12:
                if self._head[:4] != MAGIC:
                    raise TransferRejected("the decrypted bundle is not a burnedge bundle", code="bad-bundle")
                (length,) = _LENGTH.unpack_from(self._head, 4)
                if length > MAX_MANIFEST_BYTES:
                    raise TransferRejected("the bundle's manifest length is impossible", code="bad-bundle")
                need = 12 + length
        if len(self._head) < need:
            return view
        try:
            self.manifest = msgspec.json.decode(bytes(self._head[12:]), type=BundleManifest)
        except msgspec.DecodeError as exc:
            raise TransferRejected(f"the bundle's manifest is not valid: {exc}", code="bad-bundle") from exc
        names = set()
        for part in self.manifest.parts:
            check_part_name(part.name)
            if part.name in names:
                raise TransferRejected(f"part {part.name} is listed twice", code="bad-bundle")
            names.add(part.name)
        self.parts_offset = need
        self._head = bytearray()
        self._left = self.manifest.parts[0].size if self.manifest.parts else 0
        self._close_finished_parts()
        return view

    def _close_finished_parts(self) -> None:
        parts = self.manifest.parts
        while self._index < len(parts) and self._left == 0:
            if self._hash.hexdigest() != parts[self._index].sha256:
                raise TransferRejected(
                    f"part {parts[self._index].name} does not match its size and sha256 in the manifest",
                    code="part-mismatch",
                )
            self._index += 1
            self._hash = hashlib.sha256()
            self._left = parts[self._index].size if self._index < len(parts) else 0
