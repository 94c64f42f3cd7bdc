"""Backups of a clinic gateway's whole state: the encrypted file's clear header and the manifest inside it.

The file is: MAGIC, the header's length (4 bytes, big-endian), the header (JSON), the SHA-256 of the header, then
libsodium secretstream chunks of a tar archive whose last member is the manifest (see gateway/backup/).
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import msgspec

from schemas.audit import AuditHead
from schemas.base import Frozen

BACKUP_FORMAT = 1
Hex = Annotated[str, msgspec.Meta(pattern=r"\A[0-9a-f]*\Z", max_length=256)]


class BackupKdf(Frozen, kw_only=True):
    """How the file key is derived from a passphrase (libsodium's crypto_pwhash)."""

    algorithm: Literal["argon2id13"] = "argon2id13"
    salt: Hex
    opslimit: Annotated[int, msgspec.Meta(ge=1, le=64)]
    memlimit: Annotated[int, msgspec.Meta(ge=8192, le=4 * 1024**3)]
    """Bytes of memory; bounded so a forged header cannot make a restore allocate more than 4 GiB."""


class BackupRecipient(Frozen, kw_only=True):
    """The file key sealed (X25519 SealedBox) to a recipient key whose private half is kept off the gateway."""

    public_key: Hex
    fingerprint: str
    sealed_key: Hex


class BackupHeader(Frozen, kw_only=True):
    """In clear text before the encrypted stream; bound to it as the first chunk's associated data."""

    format: Literal[1] = BACKUP_FORMAT
    mode: Literal["passphrase", "recipient"]
    kdf: BackupKdf | None = None
    recipient: BackupRecipient | None = None
    key_check: Hex
    """Keyed BLAKE2b of a constant under the file key: tells a wrong passphrase or key from a damaged file."""
    stream_header: Hex
    """The secretstream header (its nonce)."""
    chunk_bytes: Annotated[int, msgspec.Meta(ge=4096, le=64 * 1024**2)]
    """Plain bytes per chunk; every chunk but the last (tagged FINAL) holds exactly this many."""
    created_at: str


class BackupFile(Frozen, kw_only=True):
    """One file of the archive, hashed as it was copied."""

    path: str
    """Path inside the archive: database/, media/, analyses/, outbox/ or keys/."""
    size: int
    sha256: str


class BackupManifest(Frozen, kw_only=True):
    """What a backup holds; the archive's last member, manifest.json."""

    format: Literal[1] = BACKUP_FORMAT
    burnedge_version: str
    created_at: str
    """When the database snapshot was taken (UTC, ISO 8601)."""
    site_id: str | None
    """This site's id from its keys, when it has keys."""
    schema_migrations: list[str]
    """The gateway database's migrations applied in the snapshot, in order."""
    audit_head: AuditHead | None
    """Sequence number and hash of the last audit entry in the snapshot (None: no entry yet)."""
    database: str
    """The database snapshot's path inside the archive."""
    files: list[BackupFile]
    settings: dict[str, dict[str, Any]]
    """The settings that differed from the defaults (paths excepted), for the restored configuration."""
    skipped: list[str] = []
    """Why something the snapshot refers to is not in the backup (e.g. a bundle delivered while copying)."""
