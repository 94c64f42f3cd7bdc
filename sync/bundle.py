"""Case bundles: a self-contained snapshot of one encounter, and the container that carries it.

Container layout (what is encrypted): b"BEB1", the manifest's length (8 bytes, big-endian), the manifest as JSON,
then every part's bytes in the manifest's order. Each part is listed with its sha256 and size; a reader checks
all of them before trusting any.
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
    if [p.name for p in manifest.parts] != [p.name for p in parts]:
        raise ValueError("the manifest must list the parts in the order they are packed")
    head = msgspec.json.encode(manifest)
    return b"".join([MAGIC, _LENGTH.pack(len(head)), head, *(p.data for p in parts)])


def unpack(container: bytes) -> tuple[BundleManifest, dict[str, bytes]]:
    """The manifest and every part, each checked against its listed size and sha256."""
    if container[:4] != MAGIC or len(container) < 12:
        raise TransferRejected("the decrypted bundle is not a burnedge bundle", code="bad-bundle")
    (length,) = _LENGTH.unpack_from(container, 4)
    if length > MAX_MANIFEST_BYTES or 12 + length > len(container):
        raise TransferRejected("the bundle's manifest length is impossible", code="bad-bundle")
    try:
        manifest = msgspec.json.decode(container[12 : 12 + length], type=BundleManifest)
    except msgspec.DecodeError as exc:
        raise TransferRejected(f"the bundle's manifest is not valid: {exc}", code="bad-bundle") from exc
    parts: dict[str, bytes] = {}
    offset = 12 + length
    for part in manifest.parts:
        check_part_name(part.name)
        if part.name in parts:
            raise TransferRejected(f"part {part.name} is listed twice", code="bad-bundle")
        data = container[offset : offset + part.size]
        if len(data) != part.size or hashlib.sha256(data).hexdigest() != part.sha256:
            raise TransferRejected(
                f"part {part.name} does not match its size and sha256 in the manifest", code="part-mismatch"
            )
        parts[part.name] = data
        offset += part.size
    if offset != len(container):
        raise TransferRejected(
            f"the bundle has {len(container) - offset} bytes beyond its listed parts", code="bad-bundle"
        )
    return manifest, parts


def check_part_name(name: str) -> None:
    path = PurePosixPath(name)
    if not name or path.is_absolute() or ".." in path.parts or "\\" in name or len(name) > 300:
        raise TransferRejected(f"part name {name!r} is not a safe relative path", code="bad-bundle")
