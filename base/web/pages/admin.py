"""The administrator's page, shared by the clinic gateway and the burn center: user accounts, phone pairing codes,
paired phones and the audit check, through the same account services as the API.

The services check the role themselves (a non-admin gets the API's 403 on the page and on every form); the page
adds no check of its own that could disagree. Every write answers 303 back to /admin with a confirmation, or the
page again with the form's errors and nothing stored. The one exception is a new pairing code: the answer to its
POST shows it, once, since a secret belongs in neither a URL nor a cookie (only its hash is stored).
"""

from __future__ import annotations

from typing import Annotated, Any

import msgspec
from litestar import Controller, get, post
from litestar.params import QueryParameter
from litestar.response import Redirect, Template

from base.web.pages.forms import FormBody, FormInvalid, field_errors, form_fields, parse_form
from base.web.pages.pairing_link import FINGERPRINT_KEY, PairingLink, pairing_link
from base.web.pages.rendering import page
from base.web.paths import IdPath
from base.web.site import AuthedRequest, SiteServices, SiteServicesDep
from schemas.accounts import PairingCode, PairingCodeRequest, PasswordReset, UserCreate
from schemas.audit import AuditVerification
from schemas.errors import Conflict, InvalidInput

DONE = {
    "user-created": "The account was created: the user can sign in now.",
    "user-deactivated": "The account was deactivated: its sessions ended and it cannot sign in.",
    "user-reactivated": "The account was reactivated: the user can sign in again.",
    "password-reset": (
        "The temporary password was set and the user's sessions ended: they must choose a new password at "
        "their next sign-in. Tell them the temporary one in person."
    ),
    "device-revoked": "The phone was revoked: its device token and its sessions stopped working.",
}
"""?done= keys -> the confirmation shown after a write (an unknown key shows nothing)."""
HELP = {
    "username": "2 to 64 characters: lower-case letters, digits, dot, dash or underscore; it starts with a letter or "
    "digit.",
    "password": "At least 10 characters.",
}
"""Help the schemas do not carry (their patterns would read badly as messages)."""
Done = Annotated[str, QueryParameter(max_length=40)]


def _with_help(fields: list) -> list:
    return [msgspec.structs.replace(f, help=HELP[f.name]) if f.name in HELP and not f.help else f for f in fields]


def _reset_fields(user_id: str, raw: Any = None, errors: dict | None = None) -> list:
    return _with_help(form_fields(PasswordReset, raw=raw, errors=errors, id_prefix=f"reset-{user_id}"))


class AdminView(msgspec.Struct, kw_only=True):
    """What the page shows besides the lists: forms shown again with their errors, a new code, an audit check."""

    user_raw: Any = None
    user_errors: dict[str, str] = {}
    reset_for: str | None = None
    reset_raw: Any = None
    reset_errors: dict[str, str] = {}
    row_errors: dict[str, str] = {}
    """User or device id -> why the action on that row did not happen."""
    pairing_raw: Any = None
    pairing_errors: dict[str, str] = {}
    pairing_code: PairingCode | None = None
    pairing_link: PairingLink | None = None
    audit: AuditVerification | None = None
    done: str | None = None


def _admin_page(request: AuthedRequest, services: SiteServices, view: AdminView, status: int = 200) -> Template:
    who = request.user
    users = services.accounts.list_users(who)  # raises Forbidden for any role but admin
    devices = services.accounts.list_devices(who)
    reset = {
        u.id: _reset_fields(u.id, view.reset_raw, view.reset_errors) if u.id == view.reset_for else _reset_fields(u.id)
        for u in users
    }
    return page(
        request,
        "admin.html",
        status_code=status,
        users=users,
        usernames={u.id: u.username for u in users},
        devices=devices,
        user_fields=_with_help(form_fields(UserCreate, raw=view.user_raw, errors=view.user_errors)),
        user_error=view.user_errors.get(""),
        reset_fields=reset,
        reset_for=view.reset_for,
        row_errors=view.row_errors,
        pairing_fields=_with_help(
            form_fields(PairingCodeRequest, raw=view.pairing_raw, errors=view.pairing_errors, id_prefix="pairing")
        ),
        pairing_error=view.pairing_errors.get(""),
        pairing_code=view.pairing_code,
        pairing_link=view.pairing_link,
        ca_fingerprint=request.app.state.get(FINGERPRINT_KEY),
        audit=view.audit,
        done=view.done,
    )


def _service_errors(exc: InvalidInput) -> dict[str, str]:
    return field_errors(exc.errors) if exc.errors else {"": exc.detail}


def _done(key: str) -> Redirect:
    return Redirect(path="/admin", query_params={"done": key}, status_code=303)


class AdminPages(Controller):
    path = "/admin"
    include_in_schema = False

    @get("/", sync_to_thread=True)
    def overview(self, request: AuthedRequest, services: SiteServicesDep, done: Done = "") -> Template:
        return _admin_page(request, services, AdminView(done=DONE.get(done)))

    @get("/audit", sync_to_thread=True)
    def audit_check(self, request: AuthedRequest, services: SiteServicesDep) -> Template:
        verification = services.verify_audit(request.user)
        return _admin_page(request, services, AdminView(audit=verification))

    @post("/users", sync_to_thread=True, status_code=303)
    def create_user(self, request: AuthedRequest, data: FormBody, services: SiteServicesDep) -> Template | Redirect:
        try:
            body = parse_form(UserCreate, data, fixed={})
            services.accounts.create_user(request.user, body)
        except FormInvalid as exc:
            return _admin_page(request, services, AdminView(user_raw=data, user_errors=field_errors(exc.errors)), 422)
        except Conflict as exc:  # the only clash of a new account: its username is taken
            return _admin_page(request, services, AdminView(user_raw=data, user_errors={"username": exc.detail}), 409)
        except InvalidInput as exc:
            return _admin_page(request, services, AdminView(user_raw=data, user_errors=_service_errors(exc)), 422)
        return _done("user-created")

    @post("/users/{user_id:str}/deactivate", sync_to_thread=True, status_code=303)
    def deactivate(self, user_id: IdPath, request: AuthedRequest, services: SiteServicesDep) -> Template | Redirect:
        return self._set_active(request, services, user_id, False)

    @post("/users/{user_id:str}/reactivate", sync_to_thread=True, status_code=303)
    def reactivate(self, user_id: IdPath, request: AuthedRequest, services: SiteServicesDep) -> Template | Redirect:
        return self._set_active(request, services, user_id, True)

    @staticmethod
    def _set_active(request: AuthedRequest, services: SiteServices, user_id: str, active: bool) -> Template | Redirect:
        try:
            services.accounts.set_active(request.user, user_id, active)
        except Conflict as exc:  # one's own account, or the last active administrator
            return _admin_page(request, services, AdminView(row_errors={user_id: exc.detail}), exc.status)
        return _done("user-reactivated" if active else "user-deactivated")

    @post("/users/{user_id:str}/reset-password", sync_to_thread=True, status_code=303)
    def reset_password(
        self, user_id: IdPath, request: AuthedRequest, data: FormBody, services: SiteServicesDep
    ) -> Template | Redirect:
        try:
            body = parse_form(PasswordReset, data, fixed={})
            services.accounts.reset_password(request.user, user_id, body.password, temporary=True)
        except FormInvalid as exc:
            view = AdminView(reset_for=user_id, reset_raw=data, reset_errors=field_errors(exc.errors))
            return _admin_page(request, services, view, 422)
        except (Conflict, InvalidInput) as exc:
            return _admin_page(request, services, AdminView(row_errors={user_id: exc.detail}), exc.status)
        return _done("password-reset")

    @post("/pairing-codes", sync_to_thread=True, status_code=201)
    def pairing_code(self, request: AuthedRequest, data: FormBody, services: SiteServicesDep) -> Template:
        try:
            body = parse_form(PairingCodeRequest, data, fixed={})
            code = services.accounts.create_pairing_code(request.user, body)
        except FormInvalid as exc:
            view = AdminView(pairing_raw=data, pairing_errors=field_errors(exc.errors))
            return _admin_page(request, services, view, 422)
        except InvalidInput as exc:
            return _admin_page(request, services, AdminView(pairing_raw=data, pairing_errors=_service_errors(exc)), 422)
        link = pairing_link(request, code.code)
        response = _admin_page(request, services, AdminView(pairing_code=code, pairing_link=link), 201)
        response.headers["Cache-Control"] = "no-store"  # the code must not come back from a cache or history
        return response

    @post("/devices/{device_id:str}/revoke", sync_to_thread=True, status_code=303)
    def revoke_device(self, device_id: IdPath, request: AuthedRequest, services: SiteServicesDep) -> Redirect:
        services.accounts.revoke_device(request.user, device_id)
        return _done("device-revoked")
