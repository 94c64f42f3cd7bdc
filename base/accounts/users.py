"""Account care: creating, listing, disabling and enabling accounts, and their passwords.

Mixed into AccountService (base/accounts/service.py), which holds the database, the password hasher and the
login throttle. An actor None is the command line on the gateway (or center) itself: whoever can run it there owns
the database already. Every change is audited and no audit entry holds a password. A reset, a password set by an
administrator and a disable end the user's sessions at once; a user's own change ends their other sessions.
"""

from __future__ import annotations

import datetime as dt
import sqlite3

from base.accounts.permissions import Principal, require_admin
from base.storage import audit
from schemas.accounts import PasswordChange, Role, User, UserCreate
from schemas.base import iso, utcnow
from schemas.errors import Conflict, InvalidInput, NotFound, WrongPassword
from schemas.ids import uuid7


def user_from_row(row) -> User:
    return User(
        id=row["id"],
        username=row["username"],
        role=Role(row["role"]),
        display_name=row["display_name"],
        active=bool(row["active"]),
        created_at=dt.datetime.fromisoformat(row["created_at"]),
        must_change_password=bool(row["must_change_password"]),
    )


def _who(actor: Principal | None) -> dict:
    return {"user_id": actor.user_id if actor else None, "device_id": actor.device_id if actor else None}


def _end_sessions(conn: sqlite3.Connection, user_id: str, keep: str | None = None) -> int:
    """Revoke the user's live sessions (all but `keep`, a session hash); how many ended."""
    return conn.execute(
        "UPDATE sessions SET revoked_at = ? WHERE user_id = ? AND revoked_at IS NULL AND token_hash IS NOT ?",
        (iso(utcnow()), user_id, keep),
    ).rowcount


def _row(conn: sqlite3.Connection, user_id: str):
    row = conn.execute("SELECT * FROM users WHERE id = ?", (user_id,)).fetchone()
    if row is None:
        raise NotFound(f"no user with id {user_id}")
    return row


class UserCare:
    def create_user(self, actor: Principal | None, body: UserCreate) -> User:
        if actor is not None:
            require_admin(actor, "manage_users")
        password_hash = self._hash(body.password)
        user_id = uuid7()
        with self.db.write() as conn:
            if conn.execute("SELECT 1 FROM users WHERE username = ?", (body.username,)).fetchone():
                raise Conflict(f"the username {body.username!r} is taken")
            conn.execute(
                "INSERT INTO users (id, username, password_hash, role, display_name, active, created_at)"
                " VALUES (?,?,?,?,?,1,?)",
                (user_id, body.username, password_hash, body.role.value, body.display_name, iso(utcnow())),
            )
            audit.append(
                conn,
                action="user.create",
                **_who(actor),
                kind="user",
                record_id=user_id,
                detail=f"{body.username} as {body.role.value}",
            )
            return user_from_row(_row(conn, user_id))

    def set_active(self, actor: Principal | None, user_id: str, active: bool) -> User:
        """Disable (ending every session at once) or re-enable an account. The last active administrator stays."""
        if actor is not None:
            require_admin(actor, "manage_users")
            if user_id == actor.user_id and not active:
                raise Conflict("you cannot disable your own account")
        with self.db.write() as conn:
            row = _row(conn, user_id)
            if not active and row["active"] and row["role"] == Role.admin.value:
                others = conn.execute(
                    "SELECT COUNT(*) FROM users WHERE role = ? AND active = 1 AND id != ?", (Role.admin.value, user_id)
                ).fetchone()[0]
                if not others:
                    raise Conflict(
                        f"{row['username']} is the last active administrator: create or enable another "
                        "administrator first, or nobody could manage accounts"
                    )
            conn.execute("UPDATE users SET active = ? WHERE id = ?", (int(active), user_id))
            if not active:
                _end_sessions(conn, user_id)
            audit.append(
                conn,
                action="user.enable" if active else "user.disable",
                **_who(actor),
                kind="user",
                record_id=user_id,
                detail=row["username"],
            )
            return user_from_row(_row(conn, user_id))

    def list_users(self, actor: Principal | None) -> list[User]:
        if actor is not None:
            require_admin(actor, "manage_users")
        return [user_from_row(r) for r in self.db.connection().execute("SELECT * FROM users ORDER BY username")]

    def user_named(self, username: str) -> User:
        row = self.db.connection().execute("SELECT * FROM users WHERE username = ?", (username,)).fetchone()
        if row is None:
            raise NotFound(f"no user named {username!r} (`burnedge users list` shows them)")
        return user_from_row(row)

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
            row = _row(conn, user_id)
            conn.execute(
                "UPDATE users SET password_hash = ?, must_change_password = ? WHERE id = ?",
                (password_hash, int(temporary), user_id),
            )
            ended = _end_sessions(conn, user_id)
            must = "; must change it at next sign-in" if temporary else ""
            audit.append(
                conn,
                action="user.password_reset",
                **_who(actor),
                kind="user",
                record_id=user_id,
                detail=f"{row['username']}{must}; {ended} sessions ended",
            )
            return user_from_row(_row(conn, user_id))

    def change_password(self, principal: Principal, body: PasswordChange) -> User:
        """A user changes their own password (clearing a reset's must-change); their other sessions end."""
        key = f"password:{principal.user_id}"  # guesses through a stolen session are slowed down like logins
        self.throttle.begin_attempt([key])
        row = self.db.connection().execute("SELECT * FROM users WHERE id = ?", (principal.user_id,)).fetchone()
        if row is None or not self._password_ok(row, body.current_password):
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
            conn.execute(
                "UPDATE users SET password_hash = ?, must_change_password = 0 WHERE id = ?",
                (password_hash, principal.user_id),
            )
            ended = _end_sessions(conn, principal.user_id, keep=principal.session_hash)
            self.throttle.succeeded(conn, key, [])
            audit.append(
                conn,
                action="user.password_change",
                **_who(principal),
                kind="user",
                record_id=principal.user_id,
                detail=f"{row['username']}; {ended} other sessions ended",
            )
            return user_from_row(_row(conn, principal.user_id))
