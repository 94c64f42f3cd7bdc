"""Plain HTTP beside HTTPS: loopback is answered as before (the demo, the command line, the machine's own browser);
another machine gets the gateway's certificate authority, the phone setup page and the health check, and is
redirected to HTTPS for everything else, so no password or patient data crosses the clinic's Wi-Fi unencrypted."""

from __future__ import annotations

from litestar.enums import ScopeType
from litestar.middleware import ASGIMiddleware
from litestar.types import ASGIApp, Receive, Scope, Send

from base.network import is_loopback
from schemas.config import GatewayConfig

OPEN_ON_HTTP = ("/ca.crt", "/phone-setup", "/health", "/static/")


class PlainHttpGate(ASGIMiddleware):
    scopes = (ScopeType.HTTP,)

    def __init__(self, gateway: GatewayConfig) -> None:
        self.https_port = gateway.https_port

    async def handle(self, scope: Scope, receive: Receive, send: Send, next_app: ASGIApp) -> None:
        client = (scope.get("client") or ("", 0))[0]
        path = scope.get("path", "")
        if scope.get("scheme") != "http" or is_loopback(client) or path.startswith(OPEN_ON_HTTP):
            await next_app(scope, receive, send)
            return
        headers = dict(scope.get("headers") or [])
        authority = headers.get(b"host", b"").decode("latin-1") or "localhost"
        host = authority[: authority.index("]") + 1] if authority.startswith("[") else authority.split(":", 1)[0]
        query = scope.get("query_string", b"").decode("latin-1")
        asked = (scope.get("raw_path") or path.encode()).decode("latin-1")  # as sent: the router trims "/app/"
        target = f"https://{host}:{self.https_port}{asked}" + (f"?{query}" if query else "")
        await send(
            {
                "type": "http.response.start",
                "status": 308,
                "headers": [(b"location", target.encode("latin-1")), (b"content-length", b"0")],
            }
        )
        await send({"type": "http.response.body", "body": b""})
