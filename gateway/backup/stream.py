"""The backup file format: a clear header, then the archive in libsodium secretstream chunks.

MAGIC | header length (4 bytes, big-endian) | header JSON | SHA-256 of the header | chunk | chunk | ... | FINAL chunk

Every chunk but the last holds exactly `chunk_bytes` plain bytes; the last is tagged FINAL, so a file cut anywhere
is told from a whole one. The header is the first chunk's associated data: changing any field of it fails
authentication. Its plain SHA-256 only tells a damaged header from a wrong passphrase.
"""

from __future__ import annotations

import hashlib
import hmac
from typing import BinaryIO

import msgspec
import nacl.exceptions
from nacl.bindings import (
    crypto_secretstream_xchacha20poly1305_ABYTES as ABYTES,
)
from nacl.bindings import (
    crypto_secretstream_xchacha20poly1305_init_pull,
    crypto_secretstream_xchacha20poly1305_init_push,
    crypto_secretstream_xchacha20poly1305_pull,
    crypto_secretstream_xchacha20poly1305_push,
    crypto_secretstream_xchacha20poly1305_state,
)
from nacl.bindings import (
    crypto_secretstream_xchacha20poly1305_TAG_FINAL as TAG_FINAL,
)
from nacl.bindings import (
    crypto_secretstream_xchacha20poly1305_TAG_MESSAGE as TAG_MESSAGE,
)

from gateway.backup.crypto import FileKey
from schemas.backup import BackupHeader
from schemas.errors import AuthenticationFailed, InvalidInput

MAGIC = b"BURNEDGE-BACKUP\x00"
MAX_HEADER = 64 * 1024


def new_stream(key: FileKey) -> tuple[crypto_secretstream_xchacha20poly1305_state, bytes]:
    state = crypto_secretstream_xchacha20poly1305_state()
    return state, crypto_secretstream_xchacha20poly1305_init_push(state, key.key)


class EncryptingWriter:
    """A write-only file object for tarfile's stream mode; `close()` writes the FINAL chunk."""

    def __init__(self, out: BinaryIO, header: BackupHeader, state):
        self.out = out
        self.state = state
        self.chunk = header.chunk_bytes
        self.ad: bytes | None = msgspec.json.encode(header)
        self.buffer = bytearray()
        self.closed = False
        out.write(MAGIC + len(self.ad).to_bytes(4, "big") + self.ad + hashlib.sha256(self.ad).digest())

    def write(self, data) -> int:
        self.buffer += data
        while len(self.buffer) >= self.chunk:
            self._push(bytes(self.buffer[: self.chunk]), TAG_MESSAGE)
            del self.buffer[: self.chunk]
        return len(data)

    def _push(self, plain: bytes, tag: int) -> None:
        self.out.write(crypto_secretstream_xchacha20poly1305_push(self.state, plain, self.ad, tag))
        self.ad = None

    def close(self) -> None:
        if not self.closed:
            self._push(bytes(self.buffer), TAG_FINAL)
            self.buffer.clear()
            self.closed = True


def read_header(handle: BinaryIO, name: str) -> tuple[BackupHeader, bytes]:
    """The clear header of an opened backup file, checked; the handle is left at the first chunk."""
    damaged = f"{name} is not a whole burnedge backup"
    if handle.read(len(MAGIC)) != MAGIC:
        raise InvalidInput(f"{name} is not a burnedge backup file (it does not start like one)")
    length = int.from_bytes(handle.read(4), "big")
    if not 0 < length <= MAX_HEADER:
        raise InvalidInput(f"{damaged}: its header is damaged; use another copy")
    raw = handle.read(length)
    if len(raw) != length or handle.read(32) != hashlib.sha256(raw).digest():
        raise InvalidInput(f"{damaged}: its header is damaged or cut short; use another copy")
    try:
        return msgspec.json.decode(raw, type=BackupHeader), raw
    except (msgspec.DecodeError, msgspec.ValidationError) as exc:
        raise InvalidInput(f"{name}: header not understood ({exc}); is it from a newer burnedge?") from exc


class DecryptingReader:
    """A read-only file object over the decrypted archive; every chunk is authenticated before its bytes are given.

    Raises InvalidInput when a chunk does not authenticate (altered or damaged), when the file ends before the
    FINAL chunk (cut short) and when bytes follow it.
    """

    def __init__(self, handle: BinaryIO, header: BackupHeader, header_raw: bytes, key: FileKey, name: str):
        if not hmac.compare_digest(key.check_value(), header.key_check):
            raise AuthenticationFailed(
                f"{name}: wrong passphrase or key; nothing was written. The backup opens "
                "only with the passphrase (or recipient key) it was made with"
            )
        self.handle, self.name, self.header = handle, name, header
        self.state = crypto_secretstream_xchacha20poly1305_state()
        crypto_secretstream_xchacha20poly1305_init_pull(self.state, bytes.fromhex(header.stream_header), key.key)
        self.ad: bytes | None = header_raw
        self.buffer = b""
        self.position = 0
        self.chunks = 0
        self.finished = False

    def _pull(self) -> None:
        offset = self.handle.tell()
        sealed = self.handle.read(self.header.chunk_bytes + ABYTES)
        if not sealed:
            raise InvalidInput(
                f"{self.name} is cut short: it ends after {self.chunks} chunks ({offset} bytes) without "
                "the final one (a copy interrupted?); nothing was written. Use another copy"
            )
        try:
            plain, tag = crypto_secretstream_xchacha20poly1305_pull(self.state, sealed, self.ad)
        except nacl.exceptions.CryptoError as exc:
            raise InvalidInput(
                f"{self.name} is damaged or was altered: chunk {self.chunks + 1} at byte {offset} "
                "does not authenticate (or the file is cut short there); nothing was written. "
                "Use another copy"
            ) from exc
        self.ad = None
        self.chunks += 1
        if tag == TAG_FINAL:
            if self.handle.read(1):
                raise InvalidInput(f"{self.name} has bytes after its final chunk: it was altered; use another copy")
            self.finished = True
        elif tag != TAG_MESSAGE or len(plain) != self.header.chunk_bytes:
            raise InvalidInput(f"{self.name}: chunk {self.chunks} is not as this format writes it; use another copy")
        self.buffer = plain
        self.position = 0

    def read(self, size: int = -1) -> bytes:
        parts = []
        while size != 0:
            if self.position >= len(self.buffer):
                if self.finished:
                    break
                self._pull()
                continue
            take = len(self.buffer) - self.position if size < 0 else min(size, len(self.buffer) - self.position)
            parts.append(self.buffer[self.position : self.position + take])
            self.position += take
            size -= take if size > 0 else 0
        return b"".join(parts)

    def drain(self) -> None:
        """Read to the FINAL chunk: what the archive reader left unread must authenticate too."""
        while not self.finished:
            self._pull()
