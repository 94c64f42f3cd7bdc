"""Session authentication as middleware: it runs before any parameter or body parsing,
so an anonymous caller learns nothing about an endpoint beyond "log in first"."""

from __future__ import annotations

from litestar.connection import ASGIConnection
from litestar.middleware import AbstractAuthenticationMiddleware, AuthenticationResult, DefineMiddleware

from schemas.errors import AuthenticationFailed

EXCLUDE_OPT_KEY = "exclude_from_auth"
"""Set on the few handlers that are the ways in: health, login, pairing."""


class SessionAuthMiddleware(AbstractAuthenticationMiddleware):
    async def authenticate_request(self, connection: ASGIConnection) -> AuthenticationResult:
        scheme, _, token = connection.headers.get("authorization", "").partition(" ")
        if scheme.lower() != "bearer" or not token.strip():
            raise AuthenticationFailed("log in first: send Authorization: Bearer <access_token>")
        principal = connection.app.state.services.accounts.authenticate(token.strip())
        return AuthenticationResult(user=principal, auth=token.strip())


session_auth = DefineMiddleware(SessionAuthMiddleware, exclude=["^/schema"], exclude_from_auth_key=EXCLUDE_OPT_KEY)
