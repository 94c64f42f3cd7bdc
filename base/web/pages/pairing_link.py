"""A pairing code as a link a phone's camera opens: the site's phone app with the code in the address's fragment
(never sent to a server, never in a log), drawn as a QR code on the administrator's page.

Only a site that serves a phone app offers it (the gateway puts the app's path in the app state under
APP_PATH_KEY). The address is the one the administrator's browser used, unless that is the machine itself
(loopback), which a phone cannot reach: then the machine's address on the clinic's network.
"""

from __future__ import annotations

from dataclasses import dataclass

import segno
from litestar import Request

from base.network import is_loopback, lan_address

APP_PATH_KEY = "phone_app_path"
FINGERPRINT_KEY = "https_ca_fingerprint"
"""Set by a site that serves HTTPS with its own authority: the authority's SHA-256 fingerprint."""


@dataclass(frozen=True)
class PairingLink:
    url: str
    svg: str
    """The QR code as inline SVG (only black modules; no text of ours inside)."""
    reachable: bool
    """False when no address a phone could reach was found (the machine has no network besides loopback)."""


def pairing_link(request: Request, code: str) -> PairingLink | None:
    """The link and QR code for `code`, or None when this site serves no phone app."""
    app_path = request.app.state.get(APP_PATH_KEY)
    if not app_path:
        return None
    host, port, reachable = request.url.hostname or "", request.url.port, True
    if is_loopback(host):
        found = lan_address()
        host, reachable = (found, True) if found else (host, False)
    if ":" in host:
        host = f"[{host}]"
    default = {"http": 80, "https": 443}.get(request.url.scheme)
    authority = host if port in (None, default) else f"{host}:{port}"
    url = f"{request.url.scheme}://{authority}{app_path}#pair={code}"
    fingerprint = request.app.state.get(FINGERPRINT_KEY)
    if fingerprint and request.url.scheme == "https":
        url += f"&fp={fingerprint.replace(':', '')[:16]}"  # the phone shows it to compare with this page
    svg = segno.make(url, error="m").svg_inline(scale=5, border=2, title="Pairing link")
    return PairingLink(url=url, svg=svg, reachable=reachable)
