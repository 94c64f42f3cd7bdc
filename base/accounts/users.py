"""Account care: creating, listing, disabling and enabling accounts, and their passwords.

Mixed into AccountService (base/accounts/service.py), which holds the database, the password hasher and the
login throttle. An actor None is the command line on the gateway (or center) itself: whoever can run it there owns
the database already. Every change is audited and no audit entry holds a password. A reset, a password set by an
administrator and a disable end the user's sessions at once; a user's own change ends their other sessions.
"""

from __future__ import annotations

from base.accounts.permissions import Principal, require_admin
from base.storage import accounts, audit
from schemas.accounts import PasswordChange, Role, User, UserCreate
from schemas.base import utcnow
from schemas.errors import Conflict, InvalidInput, NotFound, WrongPassword
from schemas.ids import uuid7


def _who(actor: Principal | None) -> dict:
    return {"user_id": actor.user_id if actor else None, "device_id": actor.device_id if actor else None}


class UserCare:
    def create_user(self, actor: Principal | None, body: UserCreate) -> User:
        if actor is not None:
            require_admin(actor, "manage_users")
        password_hash = self._hash(body.password)
        user_id = uuid7()
        with self.db.write() as conn:
            if accounts.username_taken(conn, body.username):
                raise Conflict(f"the username {body.username!r} is taken")
            accounts.insert_user(
                conn,
                user_id=user_id,
                username=body.username,
                password_hash=password_hash,
                role=body.role,
                display_name=body.display_name,
                created_at=utcnow(),
            )
            audit.append(
                conn,
                action="user.create",
                **_who(actor),
                kind="user",
                record_id=user_id,
                detail=f"{body.username} as {body.role.value}",
            )
            return accounts.get_user(conn, user_id).user

    def set_active(self, actor: Principal | None, user_id: str, active: bool) -> User:
        """Disable (ending every session at once) or re-enable an account. The last active administrator stays."""
        if actor is not None:
            require_admin(actor, "manage_users")
            if user_id == actor.user_id and not active:
                raise Conflict("you cannot disable your own account")
        with self.db.write() as conn:
            user = accounts.get_user(conn, user_id).user
            if not active and user.active and user.role == Role.admin:
                if not accounts.other_active_admins(conn, user_id):
                    raise Conflict(
                        f"{user.username} is the last active administrator: create or enable another "
                        "administrator first, or nobody could manage accounts"
                    )
            accounts.set_user_active(conn, user_id, active)
            if not active:
                accounts.end_user_sessions(conn, user_id, utcnow())
            audit.append(
                conn,
                action="user.enable" if active else "user.disable",
                **_who(actor),
                kind="user",
                record_id=user_id,
                detail=user.username,
            )
            return accounts.get_user(conn, user_id).user

    def list_users(self, actor: Principal | None) -> list[User]:
        if actor is not None:
            require_admin(actor, "manage_users")
        return accounts.list_users(self.db.connection())

    def user_named(self, username: str) -> User:
        stored = accounts.find_user_named(self.db.connection(), username)
        if stored is None:
            raise NotFound(f"no user named {username!r} (`burnedge users list` shows them)")
        return stored.user

    def reset_password(self, actor: Principal | None, user_id: str, password: str, *, temporary: bool = True) -> User:
        """An administrator sets the user's password, ending their sessions; `temporary`: they must change it at
        next sign-in. The API always resets to a temporary one; the command line may set a lasting one."""
        if actor is not None:
            require_admin(actor, "manage_users")
            if user_id == actor.user_id:
                raise Conflict(
                    "to change your own password use POST /api/v1/auth/password (it asks for the current one)"
                )
        password_hash = self._hash(password)
        with self.db.write() as conn:
            user = accounts.get_user(conn, user_id).user
            accounts.set_password(conn, user_id, password_hash, must_change=temporary)
            ended = accounts.end_user_sessions(conn, user_id, utcnow())
            must = "; must change it at next sign-in" if temporary else ""
            audit.append(
                conn,
                action="user.password_reset",
                **_who(actor),
                kind="user",
                record_id=user_id,
                detail=f"{user.username}{must}; {ended} sessions ended",
            )
            return accounts.get_user(conn, user_id).user

    def change_password(self, principal: Principal, body: PasswordChange) -> User:
        """A user changes their own password (clearing a reset's must-change); their other sessions end."""
        key = f"password:{principal.user_id}"  # guesses through a stolen session are slowed down like logins
        self.throttle.begin_attempt([key])
        stored = accounts.find_user(self.db.connection(), principal.user_id)
        if stored is None or not self._password_ok(stored, body.current_password):
            with self.db.write() as conn:
                audit.append(
                    conn,
                    action="auth.failed",
                    **_who(principal),
                    kind="user",
                    record_id=principal.user_id,
                    detail="wrong current password on a password change",
                )
            raise WrongPassword("the current password is wrong: the password was not changed")
        if body.new_password == body.current_password:
            raise InvalidInput("the new password is the current one: choose another (10+ characters)")
        password_hash = self._hash(body.new_password)
        with self.db.write() as conn:
            accounts.set_password(conn, principal.user_id, password_hash, must_change=False)
            ended = accounts.end_user_sessions(conn, principal.user_id, utcnow(), keep=principal.session_hash)
            self.throttle.succeeded(conn, key, [])
            audit.append(
                conn,
                action="user.password_change",
                **_who(principal),
                kind="user",
                record_id=principal.user_id,
                detail=f"{stored.user.username}; {ended} other sessions ended",
            )
            return accounts.get_user(conn, principal.user_id).user
