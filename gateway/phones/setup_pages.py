"""Putting the app on a phone, without signing in (nothing here is secret): the gateway's certificate authority to
install (GET /ca.crt) and the steps for Android and iOS with its fingerprint to compare (GET /phone-setup). Both are
answered on plain HTTP too: a phone cannot open the HTTPS address before it trusts the authority."""

from __future__ import annotations

import segno
from cryptography import x509
from cryptography.hazmat.primitives import serialization
from litestar import Controller, Request, Response, get
from litestar.response import Template

from base.folders import keys_dir
from base.network import is_loopback, lan_address
from base.web.pages.rendering import page
from gateway import tls
from gateway.dependencies import ServicesDep
from schemas.errors import NotFound

CA_PATH = "/ca.crt"
SETUP_PATH = "/phone-setup"


def _authority(services) -> x509.Certificate:
    config = services.config
    if not tls.https_wanted(config.gateway):
        raise NotFound(
            "this gateway serves no HTTPS ([gateway] https is off, or it listens on loopback only): phones reach it "
            "only on this machine, where no certificate is needed"
        )
    return tls.ensure_ca(keys_dir(config), config.report.clinic_name)


def _address(request: Request) -> str:
    host = request.url.hostname or ""
    if is_loopback(host):
        host = lan_address() or host
    return f"[{host}]" if ":" in host else host


class PhoneSetupPages(Controller):
    include_in_schema = False
    opt = {"exclude_from_auth": True}

    @get(CA_PATH, sync_to_thread=True)
    def authority(self, services: ServicesDep) -> Response[bytes]:
        cert = _authority(services)
        return Response(
            cert.public_bytes(serialization.Encoding.DER),
            media_type="application/x-x509-ca-cert",
            headers={"Content-Disposition": 'attachment; filename="burnedge-gateway-ca.crt"'},
        )

    @get(SETUP_PATH, sync_to_thread=True)
    def setup(self, request: Request, services: ServicesDep) -> Template:
        cert = _authority(services)
        gateway = services.config.gateway
        host = _address(request)
        setup_url = f"http://{host}:{gateway.port}{SETUP_PATH}"
        app_url = f"https://{host}:{gateway.https_port}/app/"
        return page(
            request,
            "phone_setup.html",
            fingerprint=tls.fingerprint(cert),
            authority=cert.subject.rfc4514_string(),
            until=cert.not_valid_after_utc.date().isoformat(),
            setup_url=setup_url,
            app_url=app_url,
            setup_qr=segno.make(setup_url, error="m").svg_inline(scale=5, border=2, title="Phone setup"),
            app_qr=segno.make(app_url, error="m").svg_inline(scale=5, border=2, title="The app over HTTPS"),
        )
