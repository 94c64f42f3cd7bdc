"""A pairing code as a link a phone's camera opens: the site's phone app with the code in the address's fragment
(never sent to a server, never in a log), drawn as a QR code on the administrator's page.

Only a site that serves a phone app offers it (the gateway puts the app's path in the app state under
APP_PATH_KEY). The address is the one the administrator's browser used, unless that is the machine itself
(loopback), which a phone cannot reach: then the machine's address on the clinic's network.
"""

from __future__ import annotations

import ipaddress
import socket
from dataclasses import dataclass

import segno
from litestar import Request

APP_PATH_KEY = "phone_app_path"
LOOPBACK_NAMES = {"localhost", "localhost.localdomain"}


@dataclass(frozen=True)
class PairingLink:
    url: str
    svg: str
    """The QR code as inline SVG (only black modules; no text of ours inside)."""
    reachable: bool
    """False when no address a phone could reach was found (the machine has no network besides loopback)."""


def lan_address() -> str | None:
    """The address this machine uses towards other machines (no packet is sent: a UDP socket is only pointed)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("192.0.2.1", 9))  # TEST-NET-1: the route's source address is what we want
            address = probe.getsockname()[0]
        except OSError:
            return None
    return None if ipaddress.ip_address(address).is_loopback else address


def _is_loopback(host: str) -> bool:
    if host.lower() in LOOPBACK_NAMES:
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def pairing_link(request: Request, code: str) -> PairingLink | None:
    """The link and QR code for `code`, or None when this site serves no phone app."""
    app_path = request.app.state.get(APP_PATH_KEY)
    if not app_path:
        return None
    host, port, reachable = request.url.hostname or "", request.url.port, True
    if _is_loopback(host):
        found = lan_address()
        host, reachable = (found, True) if found else (host, False)
    if ":" in host:
        host = f"[{host}]"
    default = {"http": 80, "https": 443}.get(request.url.scheme)
    authority = host if port in (None, default) else f"{host}:{port}"
    url = f"{request.url.scheme}://{authority}{app_path}#pair={code}"
    svg = segno.make(url, error="m").svg_inline(scale=5, border=2, title="Pairing link")
    return PairingLink(url=url, svg=svg, reachable=reachable)
