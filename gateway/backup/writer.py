"""`burnedge backup`: the snapshot, archived and encrypted into a file that appears only when it is whole.

The file is written under a temporary name in the target's folder, synced, then renamed: a crash or a full disk
leaves a `.partial` file that never looks like a backup. With a folder and `keep`, the newest N backups stay.
"""

from __future__ import annotations

import datetime as dt
import fcntl
import logging
import os
import re
import uuid
from dataclasses import dataclass
from pathlib import Path

import msgspec

from base import __version__
from base.storage.durable import fsync_dir
from gateway.backup import snapshot
from gateway.backup.archive import ArchiveWriter
from gateway.backup.crypto import FileKey
from gateway.backup.stream import EncryptingWriter, new_stream
from schemas.backup import BackupHeader, BackupKdf, BackupManifest, BackupRecipient
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.errors import InvalidInput

log = logging.getLogger("burnedge.backup")
SUFFIX = ".burnedge-backup"
PARTIAL = ".partial"


@dataclass(frozen=True)
class Encryption:
    key: FileKey
    kdf: BackupKdf | None = None
    recipient: BackupRecipient | None = None


def write_backup(config: Config, target: Path, encryption: Encryption) -> BackupManifest:
    """Write the backup to `target` (replaced only once the new one is whole)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    partial = target.with_name(f".{target.name}.{uuid.uuid4().hex[:8]}{PARTIAL}")
    try:
        with snapshot.take(config) as snap:
            fd = os.open(partial, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
            with os.fdopen(fd, "wb") as out:
                manifest = _archive(config, snap, out, encryption)
                out.flush()
                os.fsync(out.fileno())
        os.replace(partial, target)
        fsync_dir(target.parent)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    return manifest


def _archive(config: Config, snap: snapshot.Snapshot, out, encryption: Encryption) -> BackupManifest:
    state, stream_header = new_stream(encryption.key)
    header = BackupHeader(
        mode="recipient" if encryption.recipient else "passphrase",
        kdf=encryption.kdf,
        recipient=encryption.recipient,
        key_check=encryption.key.check_value(),
        stream_header=stream_header.hex(),
        chunk_bytes=config.backup.chunk_kib * 1024,
        created_at=iso(utcnow()),
    )
    archive = ArchiveWriter(EncryptingWriter(out, header, state))
    skipped: list[str] = []
    database = f"database/{snap.database.name}"
    archive.add_file(database, snap.database)
    for name, path, sha in snap.blobs:
        if not path.is_file():
            skipped.append(f"{name}: missing from the media store (the asset's file was lost before this backup)")
            continue
        copied = archive.add_file(name, path)
        if copied.sha256 != sha:
            skipped.append(f"{name}: damaged in the media store (its bytes no longer match its SHA-256)")
    for name, path in snap.files:
        _add_if_present(archive, name, path, skipped, "removed while copying")
    for name, path in snap.outbox:
        _add_if_present(
            archive,
            name,
            path,
            skipped,
            "delivered while copying: queue the encounter again after a restore (`burnedge sync send`)",
        )
    for name, data in snap.keys.items():
        archive.add_bytes(f"keys/{name}", data)
    manifest = BackupManifest(
        burnedge_version=__version__,
        created_at=iso(utcnow()),
        site_id=snap.site_id,
        schema_migrations=snap.migrations,
        audit_head=snap.audit_head,
        database=database,
        files=list(archive.files),
        settings=settings_of(config),
        skipped=skipped,
    )
    archive.finish(manifest)
    for line in skipped:
        log.warning("backup: %s", line)
    return manifest


def _add_if_present(archive: ArchiveWriter, name: str, path: Path, skipped: list[str], why: str) -> None:
    try:
        archive.add_file(name, path)
    except FileNotFoundError:
        skipped.append(f"{name}: {why}")


PATH_SETTINGS = {
    ("gateway", "database"),
    ("uploads", "data_dir"),
    ("jobs", "work_dir"),
    ("sync", "keys_dir"),
    ("sync", "outbox_dir"),
    ("backup", "folder"),
}
"""Where the restored state lies is set by the restore, not carried over; nor is the backup folder, so that a
restore drill never rotates away the real gateway's backups."""


def settings_of(config: Config) -> dict[str, dict[str, object]]:
    """The settings that differ from the defaults, by section, paths of the state excepted."""
    found: dict[str, dict[str, object]] = {}
    for section in Config.__struct_fields__:
        value, default = getattr(config, section), type(getattr(config, section))()
        for field in value.__struct_fields__:
            mine = getattr(value, field)
            if (section, field) not in PATH_SETTINGS and mine != getattr(default, field):
                found.setdefault(section, {})[field] = msgspec.to_builtins(mine)
    return found


def rotate(config: Config, folder: Path, keep: int, encryption: Encryption) -> tuple[Path, BackupManifest, list[Path]]:
    """A new backup in `folder`, then all but the newest `keep` removed; returns it, its manifest, the removed."""
    if keep < 1:
        raise InvalidInput("--keep must be 1 or more")
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / ".burnedge-backup.lock", "w") as lock:
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError as exc:
            raise InvalidInput(f"another backup is being written to {folder}; try again when it has finished") from exc
        for stale in folder.glob(f".burnedge-*{SUFFIX}.*{PARTIAL}"):  # left by a crash; never a whole backup
            stale.unlink(missing_ok=True)
        site = _site_label(config)
        stamp = dt.datetime.now(dt.UTC).strftime("%Y%m%dT%H%M%S%fZ")
        target = folder / f"burnedge-{site}-{stamp}{SUFFIX}"
        manifest = write_backup(config, target, encryption)
        # This site's only: several gateways may share one backup folder.
        mine = re.compile(rf"burnedge-{re.escape(site)}-(\d{{8}}T\d{{12}}Z){re.escape(SUFFIX)}")
        backups = sorted((p for p in folder.iterdir() if mine.fullmatch(p.name)), key=lambda p: p.name)
        removed = backups[:-keep]
        for old in removed:
            old.unlink(missing_ok=True)
        fsync_dir(folder)
    return target, manifest, removed


def _site_label(config: Config) -> str:
    keys = snapshot.read_keys(snapshot.StateLayout.of(config).keys)
    try:
        site = msgspec.json.decode(keys.get(snapshot.PUBLIC_FILE, b"{}")).get("site_id") or "gateway"
    except (msgspec.DecodeError, AttributeError):
        site = "gateway"
    return "".join(c for c in str(site) if c.isalnum() or c in "-_")[:64] or "gateway"
