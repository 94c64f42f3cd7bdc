"""Session authentication as middleware: it runs before any parameter or body parsing,
so an anonymous caller learns nothing about an endpoint beyond "log in first"."""

from __future__ import annotations

from litestar.connection import ASGIConnection
from litestar.middleware import AbstractAuthenticationMiddleware, AuthenticationResult, DefineMiddleware

from base.web.pages.session import SESSION_COOKIE
from schemas.errors import AuthenticationFailed, PasswordChangeRequired

EXCLUDE_OPT_KEY = "exclude_from_auth"
"""Set on the few handlers that are the ways in: health, login, pairing."""
BEFORE_PASSWORD_CHANGE_OPT_KEY = "before_password_change"
"""Set on the few handlers a session may use while its password must change (after an administrator's reset):
changing it, /auth/me and logging out. Every other one answers 403."""
MUST_CHANGE_PASSWORD = (
    "you must change your password before you go on: POST /api/v1/auth/password with the temporary password an "
    "administrator gave you as current_password and a new one (10+ characters) as new_password"
)


class SessionAuthMiddleware(AbstractAuthenticationMiddleware):
    async def authenticate_request(self, connection: ASGIConnection) -> AuthenticationResult:
        token = _bearer(connection) or connection.cookies.get(SESSION_COOKIE, "")
        if not token:
            raise AuthenticationFailed("log in first: send Authorization: Bearer <access_token>")
        principal = connection.app.state.services.accounts.authenticate(token)
        if principal.must_change_password and not connection.route_handler.opt.get(BEFORE_PASSWORD_CHANGE_OPT_KEY):
            raise PasswordChangeRequired(MUST_CHANGE_PASSWORD)
        return AuthenticationResult(user=principal, auth=token)


def _bearer(connection: ASGIConnection) -> str:
    """The Authorization header's token; a browser's pages send the session cookie instead (CSRF-checked on
    writes by base/web/pages/protection.py, which runs first)."""
    scheme, _, token = connection.headers.get("authorization", "").partition(" ")
    return token.strip() if scheme.lower() == "bearer" else ""


session_auth = DefineMiddleware(
    SessionAuthMiddleware, exclude=["^/schema", "^/static/"], exclude_from_auth_key=EXCLUDE_OPT_KEY
)
