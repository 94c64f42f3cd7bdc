"""The browser's session: the login token in an HttpOnly, SameSite=Strict cookie, and the CSRF token derived from it.

A page's CSRF token is an HMAC of the session token, keyed by that token itself: only a page the session's own
browser loaded can know it (the cookie is HttpOnly), the server keeps no extra secret, and it survives restarts.
The sign-in form has no session yet, so it is bound the same way to a random pre-session cookie.
"""

from __future__ import annotations

import hashlib
import hmac
import secrets

from litestar import Request, Response
from litestar.datastructures import Cookie

SESSION_COOKIE = "burnedge_session"
SIGN_IN_COOKIE = "burnedge_sign_in"
CSRF_FIELD = "csrf_token"
"""The hidden field of every state-changing form."""
CSRF_HEADER = "X-CSRF-Token"
"""Where scripts (htmx, the tus uploader) send it instead."""
UNSAFE_METHODS = frozenset({"POST", "PUT", "PATCH", "DELETE"})


def csrf_token(secret_material: str) -> str:
    return hmac.new(secret_material.encode(), b"burnedge-csrf-v1", hashlib.sha256).hexdigest()


def csrf_matches(secret_material: str, sent: str | None) -> bool:
    return bool(sent) and hmac.compare_digest(csrf_token(secret_material), sent)


def is_page_path(path: str) -> bool:
    """Browser pages, as opposed to the JSON API, the API docs and the static files."""
    return not path.startswith(("/api/", "/schema", "/static/", "/health"))


def request_csrf_token(request: Request) -> str:
    """The token a page rendered for this request embeds in its forms ("" when there is no session yet)."""
    material = request.cookies.get(SESSION_COOKIE) or request.cookies.get(SIGN_IN_COOKIE)
    return csrf_token(material) if material else ""


def _cookie(name: str, value: str, *, max_age: int, secure: bool) -> Cookie:
    return Cookie(key=name, value=value, max_age=max_age, path="/", httponly=True, samesite="strict", secure=secure)


def sign_in_cookie(secure: bool) -> tuple[Cookie, str]:
    """A fresh pre-session cookie and the CSRF token bound to it."""
    value = secrets.token_urlsafe(32)
    return _cookie(SIGN_IN_COOKIE, value, max_age=3600, secure=secure), csrf_token(value)


def session_cookie(token: str, max_age: int, secure: bool) -> Cookie:
    return _cookie(SESSION_COOKIE, token, max_age=max_age, secure=secure)


def clear_cookies(response: Response) -> Response:
    for name in (SESSION_COOKIE, SIGN_IN_COOKIE):
        response.delete_cookie(name, path="/")
    return response
