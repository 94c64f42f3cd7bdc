"""Two middlewares every server built on the base runs: CSRF checks on cookie-authenticated writes, and the
security headers (Content-Security-Policy without inline script, nosniff, no framing, no referrer) on every answer.
"""

from __future__ import annotations

from litestar import Request
from litestar.datastructures import MutableScopeHeaders
from litestar.enums import ScopeType
from litestar.middleware import AbstractMiddleware, DefineMiddleware
from litestar.types import Message, Receive, Scope, Send

from base.web.pages.session import (
    CSRF_FIELD,
    CSRF_HEADER,
    SESSION_COOKIE,
    SIGN_IN_COOKIE,
    UNSAFE_METHODS,
    csrf_matches,
    is_page_path,
)
from schemas.errors import Forbidden

CONTENT_SECURITY_POLICY = "; ".join(
    [
        "default-src 'self'",
        "script-src 'self' 'wasm-unsafe-eval'",
        # <model-viewer> styles its shadow DOM with <style> elements; scripts stay 'self' only.
        "style-src 'self' 'unsafe-inline'",
        "img-src 'self' data: blob:",
        # The 3D viewer decodes the GLB's textures from blob: and data: URLs.
        "connect-src 'self' blob: data:",
        "worker-src 'self' blob:",
        "font-src 'self'",
        "object-src 'none'",
        "base-uri 'none'",
        "form-action 'self'",
        "frame-ancestors 'none'",
    ]
)
SECURITY_HEADERS = {
    "Content-Security-Policy": CONTENT_SECURITY_POLICY,
    "X-Content-Type-Options": "nosniff",
    "X-Frame-Options": "DENY",
    "Referrer-Policy": "no-referrer",
    "Cross-Origin-Opener-Policy": "same-origin",
}
CSRF_FAILED = (
    "this form is out of date or did not come from this gateway's own page (CSRF check failed): nothing was "
    "stored. Reload the page and submit it again."
)


class CSRFMiddleware(AbstractMiddleware):
    """A write that a cookie would authenticate must carry the token the page was given. Callers with a bearer
    token (phones, scripts) carry no ambient credential and are not checked; a page path is checked even with no
    cookie at all (the sign-in form), so a forged cross-site sign-in fails too."""

    scopes = {ScopeType.HTTP}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        request: Request = Request(scope, receive)
        if request.method in UNSAFE_METHODS and "authorization" not in request.headers:
            material = request.cookies.get(SESSION_COOKIE) or request.cookies.get(SIGN_IN_COOKIE)
            if material or is_page_path(request.url.path):
                sent = request.headers.get(CSRF_HEADER)
                if not sent and request.content_type[0] in (
                    "application/x-www-form-urlencoded",
                    "multipart/form-data",
                ):
                    sent = (await request.form()).get(CSRF_FIELD)
                if not material or not csrf_matches(material, sent):
                    raise Forbidden(CSRF_FAILED)
        await self.app(scope, receive, send)


class SecurityHeadersMiddleware(AbstractMiddleware):
    scopes = {ScopeType.HTTP}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                headers = MutableScopeHeaders.from_message(message)
                for name, value in SECURITY_HEADERS.items():
                    if name not in headers:
                        headers[name] = value
            await send(message)

        await self.app(scope, receive, send_with_headers)


csrf_protection = DefineMiddleware(CSRFMiddleware)
security_headers = DefineMiddleware(SecurityHeadersMiddleware)
