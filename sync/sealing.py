"""End-to-end encryption of what travels between sites, from libsodium's primitives (PyNaCl); none written here.

A bundle gets a fresh 256-bit key. Each chunk of it is encrypted with XChaCha20-Poly1305 under that key with a
random nonce and the bundle id, chunk index and chunk count as associated data, so a chunk cannot be moved to
another place or bundle unnoticed. The key is sealed to the recipient's X25519 key (libsodium sealed box), so
only the recipient can open it; relays carry ciphertext only.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass

from nacl.exceptions import CryptoError
from nacl.public import PrivateKey, PublicKey, SealedBox
from nacl.secret import Aead
from nacl.utils import random

from schemas.errors import TransferRejected
from schemas.transfer import ChunkRef

KEY_BYTES = Aead.KEY_SIZE
OVERHEAD = Aead.NONCE_SIZE + Aead.MACBYTES
"""Bytes each encrypted chunk adds to its plaintext."""


@dataclass(frozen=True)
class Sealed:
    sealed_key: bytes
    chunks: list[bytes]

    @property
    def refs(self) -> list[ChunkRef]:
        return [ChunkRef(sha256=hashlib.sha256(c).hexdigest(), size=len(c)) for c in self.chunks]


def seal(plaintext: bytes, recipient_box_key: bytes, context: str, chunk_size: int) -> Sealed:
    """Encrypt `plaintext` in chunks of `chunk_size` under a fresh key sealed to the recipient."""
    sealed_key, chunks = seal_stream([plaintext], len(plaintext), recipient_box_key, context, chunk_size)
    return Sealed(sealed_key=sealed_key, chunks=list(chunks))


def seal_stream(
    pieces: Iterable[bytes], total: int, recipient_box_key: bytes, context: str, chunk_size: int
) -> tuple[bytes, Iterator[bytes]]:
    """Encrypt the `total` bytes that `pieces` yield in chunks of `chunk_size` under a fresh key sealed to the
    recipient: the sealed key, and the chunks made one at a time (the plaintext is never joined in memory)."""
    key = random(KEY_BYTES)
    box = Aead(key)
    count = max(1, -(-total // chunk_size))

    def chunks() -> Iterator[bytes]:
        index, partial = 0, bytearray()

        def encrypt(plain) -> bytes:
            nonlocal index
            index += 1
            return bytes(box.encrypt(bytes(plain), _aad(context, index - 1, count)))

        for piece in pieces:
            view = memoryview(piece)
            if partial:
                take = min(chunk_size - len(partial), len(view))
                partial += view[:take]
                view = view[take:]
                if len(partial) == chunk_size:
                    yield encrypt(partial)
                    partial.clear()
            while len(view) >= chunk_size:
                yield encrypt(view[:chunk_size])
                view = view[chunk_size:]
            partial += view
        if partial or index == 0:
            yield encrypt(partial)
        if index != count:
            raise ValueError(f"the pieces made {index} chunks, not the {count} that {total} bytes make")

    return SealedBox(PublicKey(recipient_box_key)).encrypt(key), chunks()


def unseal_key(sealed_key: bytes, own_box: PrivateKey) -> bytes:
    try:
        key = SealedBox(own_box).decrypt(sealed_key)
    except CryptoError as exc:
        raise TransferRejected("the bundle key is not sealed to this site's key", code="wrong-recipient") from exc
    if len(key) != KEY_BYTES:
        raise TransferRejected("the sealed bundle key has the wrong length", code="bad-key")
    return key


def open_chunks(key: bytes, context: str, chunks: Iterable[bytes], count: int, first_index: int = 0) -> Iterator[bytes]:
    """The plaintext of each chunk in order, the first being chunk `first_index` of `count`; raises
    TransferRejected on the first one that fails to authenticate."""
    box = Aead(key)
    for index, chunk in enumerate(chunks, start=first_index):
        try:
            yield box.decrypt(chunk, _aad(context, index, count))
        except CryptoError as exc:
            raise TransferRejected(
                f"chunk {index} of {context} fails authentication (altered or misplaced)", code="chunk-forged"
            ) from exc


def _aad(context: str, index: int, count: int) -> bytes:
    return f"burnedge/{context}/{index}/{count}".encode()
