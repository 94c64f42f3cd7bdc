"""The tar archive inside a backup: files streamed in, each hashed from the very bytes that went in.

Its last member is manifest.json. Reading accepts only plain files with relative paths under the known top folders,
so a forged archive can name nothing outside the folder it is restored into.
"""

from __future__ import annotations

import hashlib
import io
import os
import tarfile
import time
from collections.abc import Iterator
from pathlib import Path, PurePosixPath
from typing import BinaryIO

import msgspec

from schemas.backup import BackupFile, BackupManifest
from schemas.errors import InvalidInput

MANIFEST = "manifest.json"
TOP_FOLDERS = ("database", "media", "analyses", "outbox", "keys")
PIECE = 1024 * 1024


class _Hashing:
    def __init__(self, handle: BinaryIO):
        self.handle = handle
        self.digest = hashlib.sha256()

    def read(self, size: int = -1) -> bytes:
        data = self.handle.read(size)
        self.digest.update(data)
        return data


class ArchiveWriter:
    def __init__(self, out):
        self.out = out
        self.tar = tarfile.open(fileobj=out, mode="w|", format=tarfile.PAX_FORMAT)
        self.files: list[BackupFile] = []

    def add_file(self, name: str, path: Path) -> BackupFile:
        """Copy one file; its size is fixed when opened, so a file that grows meanwhile is copied up to there."""
        with open(path, "rb") as handle:
            stat = os.fstat(handle.fileno())
            hashing = _Hashing(handle)
            self.tar.addfile(self._info(name, stat.st_size, stat.st_mtime), hashing)
        return self._record(name, stat.st_size, hashing.digest.hexdigest())

    def add_bytes(self, name: str, data: bytes) -> BackupFile:
        self.tar.addfile(self._info(name, len(data), time.time()), io.BytesIO(data))
        return self._record(name, len(data), hashlib.sha256(data).hexdigest())

    def finish(self, manifest: BackupManifest) -> None:
        data = msgspec.json.format(msgspec.json.encode(manifest), indent=1)
        self.tar.addfile(self._info(MANIFEST, len(data), time.time()), io.BytesIO(data))
        self.tar.close()
        self.out.close()

    def _record(self, name: str, size: int, sha256: str) -> BackupFile:
        entry = BackupFile(path=name, size=size, sha256=sha256)
        self.files.append(entry)
        return entry

    @staticmethod
    def _info(name: str, size: int, mtime: float) -> tarfile.TarInfo:
        info = tarfile.TarInfo(name)
        info.size, info.mtime, info.mode = size, int(mtime), 0o600
        return info


def safe_name(name: str) -> str:
    path = PurePosixPath(name)
    if name == MANIFEST or (
        not path.is_absolute()
        and ".." not in path.parts
        and len(path.parts) >= 2
        and path.parts[0] in TOP_FOLDERS
        and "\\" not in name
        and "\x00" not in name
    ):
        return name
    raise InvalidInput(
        f"the backup names a file {name!r} outside the folders a backup holds: it was not made by "
        "burnedge; nothing was written"
    )


def members(source) -> Iterator[tuple[str, int, BinaryIO]]:
    """(name, size, stream) of each member in order; the stream must be read before the next member."""
    try:
        with tarfile.open(fileobj=source, mode="r|") as tar:
            for member in tar:
                name = safe_name(member.name)
                if not member.isreg():
                    raise InvalidInput(f"the backup holds {name!r}, which is not a plain file; nothing was written")
                yield name, member.size, tar.extractfile(member)
    except tarfile.TarError as exc:
        raise InvalidInput(f"the backup's archive is not readable ({exc}); nothing was written") from exc


def copy_hashed(stream: BinaryIO, sink: BinaryIO | None) -> str:
    digest = hashlib.sha256()
    while piece := stream.read(PIECE):
        digest.update(piece)
        if sink is not None:
            sink.write(piece)
    return digest.hexdigest()


def read_manifest(data: bytes) -> BackupManifest:
    try:
        return msgspec.json.decode(data, type=BackupManifest)
    except (msgspec.DecodeError, msgspec.ValidationError) as exc:
        raise InvalidInput(f"the backup's manifest is not understood ({exc}); is it from a newer burnedge?") from exc
