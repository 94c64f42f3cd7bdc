"""`burnedge restore`: check a whole backup, then write it, so a bad file never leaves a half-restored gateway.

Pass 1 decrypts and authenticates every chunk and hashes every file against the manifest, writing nothing.
Pass 2 reads the file again (same header, same key), writes into a hidden folder inside the target, checks each
file's hash again as written and the database's integrity and audit head, writes the configuration, and only
then moves everything into place.
"""

from __future__ import annotations

import os
import shutil
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from base.storage.durable import fsync_dir
from gateway.backup import archive
from gateway.backup.crypto import FileKey
from gateway.backup.restored_config import FOLDERS, render
from gateway.backup.stream import DecryptingReader, read_header
from gateway.storage import backup_copy
from schemas.backup import BackupHeader, BackupManifest
from schemas.errors import Conflict, InvalidInput, NotFound, StorageError

CONFIG_FILE = "burnedge.toml"
MAX_MANIFEST = 512 * 1024**2


@dataclass
class Restored:
    into: Path
    config: Path
    database: Path
    manifest: BackupManifest
    files: int = 0
    bytes: int = 0
    replaced: list[str] = field(default_factory=list)


def check(path: Path, unlock: Callable[[BackupHeader], FileKey]) -> tuple[BackupManifest, bytes, FileKey]:
    """Pass 1: the manifest, the header's bytes and the key, once every chunk and every file checked out."""
    if not path.is_file():
        raise NotFound(f"no backup file {path}")
    with open(path, "rb") as handle:
        header, raw = read_header(handle, str(path))
        key = unlock(header)
        reader = DecryptingReader(handle, header, raw, key, str(path))
        seen: dict[str, tuple[int, str]] = {}
        manifest_data = None
        for name, size, stream in archive.members(reader):
            if manifest_data is not None:
                raise InvalidInput(f"{path}: files follow the manifest; it was not made by burnedge")
            if name in seen:
                raise InvalidInput(f"{path} holds {name} twice; it was not made by burnedge")
            if name == archive.MANIFEST:
                if size > MAX_MANIFEST:
                    raise InvalidInput(f"{path}: the manifest is implausibly large ({size} bytes)")
                manifest_data = stream.read()
            seen[name] = (size, archive.copy_hashed(stream, None) if manifest_data is None else "")
        reader.drain()
    if manifest_data is None:
        raise InvalidInput(f"{path} has no manifest: it is not a whole burnedge backup")
    manifest = archive.read_manifest(manifest_data)
    seen.pop(archive.MANIFEST)
    listed = {f.path: (f.size, f.sha256) for f in manifest.files}
    if listed != seen:
        wrong = sorted(set(listed) ^ set(seen)) or sorted(n for n in listed if listed[n] != seen[n])
        raise InvalidInput(f"{path}: the files do not match the manifest (first: {wrong[0]}); use another copy")
    if manifest.database not in listed:
        raise InvalidInput(f"{path}: the manifest names no database")
    return manifest, raw, key


def restore(path: Path, into: Path, unlock: Callable[[BackupHeader], FileKey], *, force: bool = False) -> Restored:
    _refuse_non_empty(into, force)
    manifest, header_raw, key = check(path, unlock)
    _refuse_non_empty(into, force)  # again: pass 1 of a large backup takes a while
    database_name = Path(manifest.database).name
    expected = {f.path: f.sha256 for f in manifest.files}
    created = not into.exists()
    into.mkdir(mode=0o700, parents=True, exist_ok=True)
    staging = into / f".burnedge-restore-{uuid.uuid4().hex[:8]}"
    staging.mkdir(mode=0o700)
    try:
        result = Restored(into=into, config=into / CONFIG_FILE, database=into / database_name, manifest=manifest)
        with open(path, "rb") as handle:
            header, raw = read_header(handle, str(path))
            if raw != header_raw:
                raise InvalidInput(f"{path} changed between the check and the restore; nothing was restored")
            reader = DecryptingReader(handle, header, raw, key, str(path))
            for name, _size, stream in archive.members(reader):
                if name == archive.MANIFEST:
                    stream.read()
                    continue
                result.files += 1
                result.bytes += _write(
                    staging / _target(name, manifest.database, database_name), stream, expected.get(name), path
                )
            reader.drain()
        _check_database(staging / database_name, manifest)
        (staging / CONFIG_FILE).write_text(render(manifest.settings, into, database_name, manifest.created_at))
        _move_into_place(staging, into, result)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        if created and not any(into.iterdir()):
            into.rmdir()
        raise
    staging.rmdir()
    return result


def _refuse_non_empty(into: Path, force: bool) -> None:
    if into.exists() and not into.is_dir():
        raise InvalidInput(f"{into} is a file, not a folder: restore into a new folder")
    if not force and into.is_dir() and any(into.iterdir()):
        raise Conflict(
            f"{into} is not empty: restore into a new folder, or add --force to restore into it anyway "
            "(what has the same name as the restored state is replaced; stop any gateway using it)"
        )


def _target(name: str, database: str, database_name: str) -> str:
    if name == database:
        return database_name
    top, rest = name.split("/", 1)
    if top not in FOLDERS:
        raise InvalidInput(f"the backup holds {name}, which is no part of a gateway's state")
    return f"{FOLDERS[top]}/{rest}"


def _write(target: Path, stream, sha256: str | None, path: Path) -> int:
    if sha256 is None:
        raise InvalidInput(f"{path} changed between the check and the restore; nothing was restored")
    target.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    fd = os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "wb") as sink:
        digest = archive.copy_hashed(stream, sink)
        sink.flush()
        os.fsync(sink.fileno())
        written = sink.tell()
    if digest != sha256:
        raise InvalidInput(f"{path} changed between the check and the restore ({target.name}); nothing was restored")
    return written


def _check_database(database: Path, manifest: BackupManifest) -> None:
    try:
        found = backup_copy.check_copy(database)
    except StorageError as exc:
        raise InvalidInput(f"the backed-up database does not open ({exc.detail}); use another copy") from exc
    if found.integrity != "ok":
        raise InvalidInput(
            f"the backed-up database fails SQLite's integrity check ({found.integrity}); use another copy"
        )
    if found.audit_head != manifest.audit_head:
        raise InvalidInput(
            "the backed-up database's last audit entry is not the one its manifest names; use another copy"
        )


def _move_into_place(staging: Path, into: Path, result: Restored) -> None:
    database_name = result.database.name
    for suffix in ("-wal", "-shm", "-journal"):  # another database's log would be replayed into the restored one
        stale = into / (database_name + suffix)
        if stale.exists():
            stale.unlink()
            result.replaced.append(stale.name)
    for entry in sorted(staging.iterdir()):
        dest = into / entry.name
        if dest.is_dir() and not dest.is_symlink():
            shutil.rmtree(dest)
            result.replaced.append(entry.name)
        elif dest.exists() or dest.is_symlink():
            dest.unlink()
            result.replaced.append(entry.name)
        os.replace(entry, dest)
    fsync_dir(into)
