"""Signing in and out of the pages, and changing one's own password: shared by the gateway and the center.

The form's fields are the API's own Structs (LoginRequest, PasswordChange); the session is the API's, carried in
a cookie (base/web/pages/session.py)."""

from __future__ import annotations

import msgspec
from litestar import Controller, Request, get, post
from litestar.response import Redirect, Template

from base.web.authentication import BEFORE_PASSWORD_CHANGE_OPT_KEY, EXCLUDE_OPT_KEY
from base.web.pages.forms import FormBody
from base.web.pages.rendering import page
from base.web.pages.session import (
    SIGN_IN_COOKIE,
    clear_cookies,
    session_cookie,
    sign_in_cookie,
)
from base.web.site import AuthedRequest, SiteServicesDep, client_address
from schemas.accounts import PasswordChange
from schemas.base import utcnow
from schemas.errors import AuthenticationFailed, InvalidInput, TooManyAttempts, WrongPassword


def safe_next(target: object) -> str:
    """Only a path on this server: never "//elsewhere" or "https://elsewhere" (an open redirect)."""
    text = target if isinstance(target, str) else ""
    if not text.startswith("/") or text.startswith("//") or "\\" in text or text.startswith("/sign-"):
        return "/"
    return text


def _secure(request: Request) -> bool:
    """Secure cookies when configured, and always on a page served over HTTPS (the gateway's own, for phones)."""
    return request.app.state.services.config.security.cookie_secure or request.url.scheme == "https"


class SignInController(Controller):
    path = "/"
    include_in_schema = False

    @get("/sign-in", sync_to_thread=False, opt={EXCLUDE_OPT_KEY: True})
    def form(self, request: Request, next: str = "/") -> Template:
        response = page(request, "sign_in.html", next=safe_next(next), username="", error=None)
        if not request.cookies.get(SIGN_IN_COOKIE):
            cookie, token = sign_in_cookie(_secure(request))
            response.context["csrf_token"] = token
            response.cookies.append(cookie)
        return response

    @post("/sign-in", sync_to_thread=True, opt={EXCLUDE_OPT_KEY: True}, status_code=303)
    def sign_in(self, request: Request, data: FormBody, services: SiteServicesDep) -> Template | Redirect:
        username = str(data.get("username", "")).strip()[:200]
        target = safe_next(data.get("next"))
        try:
            session = services.accounts.login(
                username, str(data.get("password", "")), client=client_address(request), device_token=None
            )
        except (AuthenticationFailed, TooManyAttempts) as exc:
            status = 429 if isinstance(exc, TooManyAttempts) else 401
            return page(request, "sign_in.html", status_code=status, next=target, username=username, error=exc.detail)
        if session.user.must_change_password:
            target = "/account/password"
        response = Redirect(path=target, status_code=303)
        ttl = max(1, int((session.expires_at - utcnow()).total_seconds()))
        response.cookies.append(session_cookie(session.access_token, ttl, _secure(request)))
        response.delete_cookie(SIGN_IN_COOKIE, path="/")
        return response

    @post("/sign-out", sync_to_thread=True, status_code=303, opt={BEFORE_PASSWORD_CHANGE_OPT_KEY: True})
    def sign_out(self, request: AuthedRequest, services: SiteServicesDep) -> Redirect:
        services.accounts.logout(request.user)
        return clear_cookies(Redirect(path="/sign-in", status_code=303))

    @get("/account/password", sync_to_thread=False, opt={BEFORE_PASSWORD_CHANGE_OPT_KEY: True})
    def password_form(self, request: AuthedRequest) -> Template:
        return page(request, "password.html", error=None, done=False)

    @post("/account/password", sync_to_thread=True, opt={BEFORE_PASSWORD_CHANGE_OPT_KEY: True}, status_code=200)
    def change_password(self, request: AuthedRequest, data: FormBody, services: SiteServicesDep) -> Template:
        try:
            body = msgspec.convert(
                {"current_password": data.get("current_password", ""), "new_password": data.get("new_password", "")},
                PasswordChange,
            )
            services.accounts.change_password(request.user, body)
        except msgspec.ValidationError as exc:
            return page(request, "password.html", status_code=422, error=_password_problem(exc), done=False)
        except (WrongPassword, InvalidInput, TooManyAttempts) as exc:
            return page(request, "password.html", status_code=exc.status, error=exc.detail, done=False)
        return page(request, "password.html", error=None, done=True)


def _password_problem(exc: msgspec.ValidationError) -> str:
    if "new_password" in str(exc):
        return "the new password must have at least 10 characters"
    return "enter your current password"
