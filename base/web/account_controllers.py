"""Login, logout, phone pairing, users and devices."""

from __future__ import annotations

from typing import Annotated

from litestar import Controller, Request, get, post
from litestar.params import HeaderParameter, JSONBody, QueryParameter

from base.accounts.permissions import require_admin
from base.storage import audit
from base.web.authentication import BEFORE_PASSWORD_CHANGE_OPT_KEY
from base.web.paths import IdPath
from base.web.problems import BODY, ONE, SESSION, problems
from base.web.site import AuthedRequest, SiteServicesDep, client_address
from schemas.accounts import (
    Device,
    DeviceToken,
    Identity,
    LoginRequest,
    PairingCode,
    PairingCodeRequest,
    PairRequest,
    PasswordChange,
    PasswordReset,
    Session,
    User,
    UserCreate,
)
from schemas.audit import AuditEntry, AuditVerification


class AuthController(Controller):
    path = "/api/v1/auth"
    tags = ["auth"]

    @post(
        "/login",
        sync_to_thread=True,
        status_code=200,
        exclude_from_auth=True,
        summary="Exchange username and password for a session token",
        responses=problems(*BODY, 401, 429),
    )
    def login(
        self,
        request: Request,
        data: JSONBody[LoginRequest],
        services: SiteServicesDep,
        device_token: Annotated[str | None, HeaderParameter(name="X-Device-Token")] = None,
    ) -> Session:
        return services.accounts.login(
            data.username, data.password, client=client_address(request), device_token=device_token
        )

    @post(
        "/pair",
        sync_to_thread=True,
        status_code=201,
        exclude_from_auth=True,
        summary="Exchange a one-time pairing code for this phone's device token",
        responses=problems(*BODY, 401, 429),
    )
    def pair(self, request: Request, data: JSONBody[PairRequest], services: SiteServicesDep) -> DeviceToken:
        return services.accounts.pair(data, client=client_address(request))

    @post(
        "/logout",
        sync_to_thread=True,
        status_code=204,
        summary="End this session",
        responses=problems(401),
        opt={BEFORE_PASSWORD_CHANGE_OPT_KEY: True},
    )
    def logout(self, request: AuthedRequest, services: SiteServicesDep) -> None:
        services.accounts.logout(request.user)

    @get(
        "/me",
        sync_to_thread=False,
        summary="Who am I",
        responses=problems(401),
        opt={BEFORE_PASSWORD_CHANGE_OPT_KEY: True},
    )
    def me(self, request: AuthedRequest) -> Identity:
        p = request.user
        return Identity(
            user_id=p.user_id,
            username=p.username,
            role=p.role,
            device_id=p.device_id,
            must_change_password=p.must_change_password,
        )

    @post(
        "/password",
        sync_to_thread=True,
        status_code=200,
        opt={BEFORE_PASSWORD_CHANGE_OPT_KEY: True},
        summary="Change your own password (needs the current one); your other sessions end, this one stays",
        responses=problems(*BODY, 401, 403, 422, 429),
    )
    def change_password(
        self, data: JSONBody[PasswordChange], request: AuthedRequest, services: SiteServicesDep
    ) -> User:
        return services.accounts.change_password(request.user, data)


class AdminController(Controller):
    path = "/api/v1/admin"
    tags = ["admin"]

    @post("/users", sync_to_thread=True, summary="Create a user account", responses=problems(*BODY, *SESSION, 409))
    def create_user(self, data: JSONBody[UserCreate], request: AuthedRequest, services: SiteServicesDep) -> User:
        return services.accounts.create_user(request.user, data)

    @post(
        "/users/{user_id:str}/disable",
        sync_to_thread=True,
        status_code=200,
        summary="Disable an account: its sessions end at once",
        responses=problems(*ONE, 409),
    )
    def disable_user(self, user_id: IdPath, request: AuthedRequest, services: SiteServicesDep) -> User:
        return services.accounts.set_active(request.user, user_id, False)

    @post(
        "/users/{user_id:str}/enable",
        sync_to_thread=True,
        status_code=200,
        summary="Re-enable an account",
        responses=problems(*ONE, 409),
    )
    def enable_user(self, user_id: IdPath, request: AuthedRequest, services: SiteServicesDep) -> User:
        return services.accounts.set_active(request.user, user_id, True)

    @post(
        "/users/{user_id:str}/reset-password",
        sync_to_thread=True,
        status_code=200,
        summary="Set a temporary password the user must change at next sign-in; their sessions end at once",
        responses=problems(*BODY, *ONE, 409),
    )
    def reset_password(
        self, user_id: IdPath, data: JSONBody[PasswordReset], request: AuthedRequest, services: SiteServicesDep
    ) -> User:
        return services.accounts.reset_password(request.user, user_id, data.password, temporary=True)

    @get("/users", sync_to_thread=False, summary="List user accounts", responses=problems(*SESSION))
    def list_users(self, request: AuthedRequest, services: SiteServicesDep) -> list[User]:
        return services.accounts.list_users(request.user)

    @post(
        "/pairing-codes",
        sync_to_thread=True,
        summary="Create a short-lived one-time code to pair a phone",
        responses=problems(*BODY, *SESSION),
    )
    def pairing_code(
        self, data: JSONBody[PairingCodeRequest], request: AuthedRequest, services: SiteServicesDep
    ) -> PairingCode:
        return services.accounts.create_pairing_code(request.user, data)

    @get("/devices", sync_to_thread=False, summary="List paired phones", responses=problems(*SESSION))
    def devices(self, request: AuthedRequest, services: SiteServicesDep) -> list[Device]:
        return services.accounts.list_devices(request.user)

    @post(
        "/devices/{device_id:str}/revoke",
        sync_to_thread=True,
        status_code=200,
        summary="Revoke a phone: its token and sessions stop working at once",
        responses=problems(*ONE),
    )
    def revoke(self, device_id: IdPath, request: AuthedRequest, services: SiteServicesDep) -> Device:
        return services.accounts.revoke_device(request.user, device_id)

    @get(
        "/audit",
        sync_to_thread=False,
        summary="Audit entries after a sequence number",
        responses=problems(400, *SESSION),
    )
    def audit_entries(
        self,
        request: AuthedRequest,
        services: SiteServicesDep,
        after: Annotated[int, QueryParameter(ge=0, le=2**63 - 1, description="Last sequence number already read")] = 0,
        limit: Annotated[int, QueryParameter(ge=1, le=1000)] = 200,
    ) -> list[AuditEntry]:
        require_admin(request.user, "read_audit")
        return list(audit.entries(services.db.connection(), after_seq=after, limit=limit))

    @get(
        "/audit/verify",
        sync_to_thread=True,
        summary="Check the audit hash chain; names the first broken entry",
        responses=problems(*SESSION),
    )
    def audit_verify(self, request: AuthedRequest, services: SiteServicesDep) -> AuditVerification:
        return services.verify_audit(request.user)
