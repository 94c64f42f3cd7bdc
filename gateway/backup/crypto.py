"""Keys of a backup file: a passphrase through Argon2id, or a random file key sealed to a recipient's X25519 key.

Everything here is a libsodium call through PyNaCl; nothing cryptographic is written by hand.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import msgspec
import nacl.exceptions
import nacl.hash
import nacl.pwhash.argon2id as argon2id
import nacl.utils
from nacl.bindings import crypto_secretstream_xchacha20poly1305_KEYBYTES as KEY_BYTES
from nacl.encoding import HexEncoder, RawEncoder
from nacl.public import PrivateKey, PublicKey, SealedBox

from schemas.backup import BackupKdf, BackupRecipient
from schemas.base import Frozen
from schemas.errors import AuthenticationFailed, InvalidInput, NotFound

MIN_PASSPHRASE = 12
PUBLIC_FILE = "backup-recipient.pub.json"
PRIVATE_FILE = "backup-recipient.key.json"
_KEY_CHECK = b"burnedge backup key check v1"


class _RecipientPublic(Frozen):
    kind: str
    public_key: str
    fingerprint: str


class _RecipientPrivate(Frozen):
    kind: str
    private_key: str
    fingerprint: str


@dataclass(frozen=True)
class FileKey:
    key: bytes

    def check_value(self) -> str:
        return nacl.hash.blake2b(_KEY_CHECK, key=self.key, digest_size=32, encoder=HexEncoder).decode()


def fingerprint(public_key: bytes) -> str:
    digest = nacl.hash.blake2b(public_key, digest_size=10, encoder=HexEncoder).decode()
    return "-".join(digest[i : i + 4] for i in range(0, len(digest), 4))


def new_passphrase_key(passphrase: str, opslimit: int, memlimit: int) -> tuple[FileKey, BackupKdf]:
    if len(passphrase) < MIN_PASSPHRASE:
        raise InvalidInput(
            f"the backup passphrase must have at least {MIN_PASSPHRASE} characters (a few words "
            "are easy to remember and hard to guess)"
        )
    kdf = BackupKdf(salt=nacl.utils.random(argon2id.SALTBYTES).hex(), opslimit=opslimit, memlimit=memlimit)
    return passphrase_key(passphrase, kdf), kdf


def passphrase_key(passphrase: str, kdf: BackupKdf) -> FileKey:
    key = argon2id.kdf(
        KEY_BYTES, passphrase.encode("utf-8"), bytes.fromhex(kdf.salt), opslimit=kdf.opslimit, memlimit=kdf.memlimit
    )
    return FileKey(key)


def new_recipient_key(public_file: Path) -> tuple[FileKey, BackupRecipient]:
    public = load_recipient(public_file)
    key = nacl.utils.random(KEY_BYTES)
    sealed = SealedBox(public).encrypt(key)
    raw = public.encode(RawEncoder)
    return FileKey(key), BackupRecipient(public_key=raw.hex(), fingerprint=fingerprint(raw), sealed_key=sealed.hex())


def recipient_key(identity_file: Path, recipient: BackupRecipient) -> FileKey:
    private = load_identity(identity_file)
    mine = fingerprint(private.public_key.encode(RawEncoder))
    if mine != recipient.fingerprint:
        raise AuthenticationFailed(
            f"this backup is encrypted to recipient key {recipient.fingerprint}, but "
            f"{identity_file} is key {mine}: use the private key made with that one"
        )
    try:
        return FileKey(SealedBox(private).decrypt(bytes.fromhex(recipient.sealed_key)))
    except nacl.exceptions.CryptoError as exc:
        raise InvalidInput(
            "the backup's sealed file key does not open with the right private key: the file's "
            "header is damaged; use another copy"
        ) from exc


def keygen(folder: Path) -> tuple[Path, Path, str]:
    """A recipient key pair: the public half stays on the gateway, the private half goes off it."""
    folder.mkdir(parents=True, exist_ok=True)
    public_path, private_path = folder / PUBLIC_FILE, folder / PRIVATE_FILE
    for path in (public_path, private_path):
        if path.exists():
            raise InvalidInput(
                f"{path} already exists: keep it (older backups need its private half) or use another folder"
            )
    key = PrivateKey.generate()
    raw = key.public_key.encode(RawEncoder)
    print_ = fingerprint(raw)
    private = _RecipientPrivate(
        kind="burnedge-backup-identity", private_key=key.encode(HexEncoder).decode(), fingerprint=print_
    )
    fd = os.open(private_path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    with os.fdopen(fd, "wb") as handle:
        handle.write(msgspec.json.encode(private) + b"\n")
    public = _RecipientPublic(kind="burnedge-backup-recipient", public_key=raw.hex(), fingerprint=print_)
    public_path.write_bytes(msgspec.json.encode(public) + b"\n")
    return public_path, private_path, print_


def load_recipient(path: Path) -> PublicKey:
    public = _read(path, _RecipientPublic, "burnedge-backup-recipient", "a backup recipient's public key")
    return PublicKey(bytes.fromhex(public.public_key))


def load_identity(path: Path) -> PrivateKey:
    private = _read(path, _RecipientPrivate, "burnedge-backup-identity", "a backup recipient's private key")
    return PrivateKey(bytes.fromhex(private.private_key))


def _read(path: Path, struct, kind: str, what: str):
    try:
        value = msgspec.json.decode(path.read_bytes(), type=struct)
        if value.kind != kind:
            raise ValueError(f"it holds {value.kind}")
        bytes.fromhex(value.public_key if hasattr(value, "public_key") else value.private_key)
    except FileNotFoundError as exc:
        raise NotFound(f"no file {path} ({what}, made by `burnedge backup keygen`)") from exc
    except (OSError, ValueError, msgspec.DecodeError, msgspec.ValidationError) as exc:
        raise InvalidInput(f"{path} is not {what} made by `burnedge backup keygen`: {exc}") from exc
    return value
