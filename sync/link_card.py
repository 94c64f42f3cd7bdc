"""A site's public keys as its administrator hands them over on a page: the `site.pub.json` file, or a QR code of
the same JSON that the other site's administrator photographs and uploads. Nothing in them is secret; what makes
them trusted is the two people comparing the fingerprints by phone before enrolling.
"""

from __future__ import annotations

from dataclasses import dataclass

import msgspec
import numpy as np
import segno

from schemas.errors import InvalidInput
from schemas.transfer import SiteIdentity, SiteRole
from sync.keys import check_identity, fingerprint

MAX_CARD_BYTES = 20 * 1024 * 1024
"""A photo of a QR code from a phone is a few MB; a keys file under 1 kB."""
ROLE_WORDS = {SiteRole.center: "a burn center", SiteRole.clinic: "a clinic"}


@dataclass(frozen=True)
class CardToCheck:
    """Public keys read from an upload, shown with their fingerprint before anyone trusts them."""

    identity: SiteIdentity
    fingerprint: str
    text: str
    """The keys as compact JSON: the confirmation form carries them back (checked again there)."""

    @classmethod
    def of(cls, identity: SiteIdentity) -> CardToCheck:
        return cls(identity, fingerprint(identity), msgspec.json.encode(identity).decode())


def card_json(identity: SiteIdentity) -> bytes:
    """The keys file's content: the same bytes `burnedge keys init` writes to site.pub.json."""
    return msgspec.json.format(msgspec.json.encode(identity)) + b"\n"


def card_qr_svg(identity: SiteIdentity) -> str:
    """The public keys as a QR code, inline SVG (compact JSON; error correction M survives a phone's photo)."""
    return segno.make(msgspec.json.encode(identity), error="m").svg_inline(
        scale=4, border=4, light="#fff", omitsize=True, title=f"Public keys of {identity.name}"
    )


def read_card(data: bytes, wanted: SiteRole) -> SiteIdentity:
    """The public keys in an uploaded keys file or photo of a QR code, checked and of the role wanted."""
    if not data:
        raise InvalidInput("nothing was uploaded: choose the site.pub.json file or a photo of the QR code")
    if len(data) > MAX_CARD_BYTES:
        raise InvalidInput("this file is too large for a keys file or a photo of a QR code")
    text = data if data.lstrip()[:1] == b"{" else _qr_text(data)
    return identity_from_text(text, wanted)


def identity_from_text(text: bytes | str, wanted: SiteRole) -> SiteIdentity:
    """Public keys from their JSON (a keys file, a QR code, the hidden field of a confirmation form)."""
    try:
        identity = msgspec.json.decode(text, type=SiteIdentity)
    except (msgspec.DecodeError, msgspec.ValidationError) as exc:
        raise InvalidInput(
            f"this is not a site's public keys ({exc}): upload the site.pub.json file the other site's page offers,"
            " or a photo of its QR code"
        ) from exc
    check_identity(identity)
    if identity.role is not wanted:
        raise InvalidInput(
            f"these are the keys of {ROLE_WORDS[identity.role]} ({identity.name}); here the keys of "
            f"{ROLE_WORDS[wanted]} are needed"
        )
    return identity


def confirmed_card(card: str, wanted: SiteRole, compared: bool) -> SiteIdentity:
    """The keys a confirmation form carries back, once the person ticked that the fingerprints match."""
    identity = identity_from_text(card, wanted)
    if not compared:
        raise InvalidInput(
            f"compare the fingerprint with the administrator of {ROLE_WORDS[wanted]} by phone first, then tick the box"
        )
    return identity


def _qr_text(data: bytes) -> bytes:
    import cv2  # only when a photo is read: the burn center's server otherwise loads no OpenCV (tests/test_layers.py)

    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise InvalidInput("this is neither a keys file (site.pub.json) nor a photo (JPEG or PNG) of a QR code")
    # A photo cropped tight loses the white margin the detectors need: give it one. OpenCV's ArUco-based detector
    # reads screenshots and photos whose modules are not whole pixels, where the classic one often fails.
    margin = max(image.shape) // 10
    framed = cv2.copyMakeBorder(image, margin, margin, margin, margin, cv2.BORDER_CONSTANT, value=255)
    text = ""
    for detector in (cv2.QRCodeDetectorAruco(), cv2.QRCodeDetector()):
        text, _, _ = detector.detectAndDecode(framed)
        if text:
            break
    if not text:
        raise InvalidInput(
            "no QR code could be read in this photo: photograph the code straight on so that it fills most of the"
            " picture, in focus and without glare, or upload the site.pub.json file instead"
        )
    return text.encode()
