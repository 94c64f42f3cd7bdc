"""A site's keys: Ed25519 to sign what it sends, X25519 to open what is sealed to it (PyNaCl / libsodium).

The private keys live in one file readable by the service's user only; the public half is the `SiteIdentity` a
peer enrols. Fingerprints are what two people read to each other over the phone before trusting a key.
"""

from __future__ import annotations

import hashlib
import os
from dataclasses import dataclass
from pathlib import Path

import msgspec
from nacl.encoding import HexEncoder
from nacl.exceptions import BadSignatureError
from nacl.public import PrivateKey
from nacl.signing import SigningKey, VerifyKey

from schemas.base import Frozen, ShortText
from schemas.errors import InvalidInput, MissingKeys
from schemas.transfer import PROTOCOL, SignedEnvelope, SiteId, SiteIdentity, SiteRole

PRIVATE_FILE = "site.key"
PUBLIC_FILE = "site.pub.json"


class _PrivateKeys(Frozen):
    site_id: SiteId
    role: SiteRole
    name: ShortText
    sign_seed: str
    box_secret: str


@dataclass(frozen=True)
class SiteKeys:
    """This site's own key pair."""

    site_id: str
    role: SiteRole
    name: str
    signing: SigningKey
    box: PrivateKey

    @property
    def identity(self) -> SiteIdentity:
        box_key = self.box.public_key.encode(HexEncoder).decode()
        return SiteIdentity(
            site_id=self.site_id,
            role=self.role,
            name=self.name,
            sign_key=self.signing.verify_key.encode(HexEncoder).decode(),
            box_key=box_key,
            box_key_signature=self.signing.sign(bytes.fromhex(box_key)).signature.hex(),
        )

    def sign(self, kind: str, message: msgspec.Struct) -> SignedEnvelope:
        body = msgspec.msgpack.encode(message)
        signature = self.signing.sign(_signed_bytes(kind, self.site_id, body)).signature
        return SignedEnvelope(protocol=PROTOCOL, kind=kind, signer=self.site_id, body=body, signature=signature)


def init_keys(keys_dir: Path, site_id: str, role: SiteRole, name: str, *, force: bool = False) -> SiteKeys:
    """Make a site's keys; refuses to replace existing ones unless `force` (peers would have to enrol again)."""
    keys_dir.mkdir(parents=True, exist_ok=True)
    private = keys_dir / PRIVATE_FILE
    if private.exists() and not force:
        raise InvalidInput(
            f"{private} already exists: this site has keys (its peers trust them). "
            "Use --force only to replace them, then enrol the new keys at every peer."
        )
    try:
        msgspec.convert(site_id, SiteId)
    except msgspec.ValidationError as exc:
        raise InvalidInput(f"site id {site_id!r} is not usable: {exc}") from exc
    keys = SiteKeys(site_id=site_id, role=role, name=name, signing=SigningKey.generate(), box=PrivateKey.generate())
    stored = _PrivateKeys(
        site_id=site_id,
        role=role,
        name=name,
        sign_seed=keys.signing.encode(HexEncoder).decode(),
        box_secret=keys.box.encode(HexEncoder).decode(),
    )
    tmp = private.with_suffix(".tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "wb") as handle:
        handle.write(msgspec.json.encode(stored))
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, private)
    (keys_dir / PUBLIC_FILE).write_bytes(msgspec.json.format(msgspec.json.encode(keys.identity)) + b"\n")
    return keys


def load_keys(keys_dir: Path) -> SiteKeys:
    private = keys_dir / PRIVATE_FILE
    try:
        stored = msgspec.json.decode(private.read_bytes(), type=_PrivateKeys)
    except FileNotFoundError as exc:
        raise MissingKeys(
            f"this site has no keys yet (in {keys_dir}): a clinic's administrator makes them on the Burn center page,"
            " step 1; from a shell, `burnedge keys init`"
        ) from exc
    except msgspec.DecodeError as exc:
        raise InvalidInput(f"{private} is damaged ({exc}): restore it from backup") from exc
    return SiteKeys(
        site_id=stored.site_id,
        role=stored.role,
        name=stored.name,
        signing=SigningKey(stored.sign_seed, encoder=HexEncoder),
        box=PrivateKey(stored.box_secret, encoder=HexEncoder),
    )


def fingerprint(identity: SiteIdentity) -> str:
    """SHA-256 of both public keys, as 16 groups of 4 hex digits."""
    digest = hashlib.sha256(bytes.fromhex(identity.sign_key) + bytes.fromhex(identity.box_key)).hexdigest()
    return " ".join(digest[i : i + 4] for i in range(0, len(digest), 4)).upper()


def check_identity(identity: SiteIdentity) -> None:
    """A public identity is well-formed and its box key is signed by its sign key."""
    try:
        verify = VerifyKey(identity.sign_key, encoder=HexEncoder)
        verify.verify(bytes.fromhex(identity.box_key), bytes.fromhex(identity.box_key_signature))
        if len(bytes.fromhex(identity.box_key)) != 32:
            raise ValueError("box key is not 32 bytes")
    except (ValueError, TypeError, BadSignatureError) as exc:
        raise InvalidInput(
            f"the public keys of {identity.site_id} are not valid ({exc}): ask the site to send its site.pub.json again"
        ) from exc


def verify_envelope(envelope: SignedEnvelope, identity: SiteIdentity) -> None:
    """Raise BadSignatureError unless `identity` signed this envelope."""
    verify = VerifyKey(identity.sign_key, encoder=HexEncoder)
    verify.verify(_signed_bytes(envelope.kind, envelope.signer, envelope.body), envelope.signature)


def _signed_bytes(kind: str, signer: str, body: bytes) -> bytes:
    # The kind and signer are signed too: a signed body cannot be replayed as another kind of message.
    return f"burnedge/{PROTOCOL}/{kind}/{signer}\n".encode() + body
