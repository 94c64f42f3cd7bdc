"""`burnedge users`: account care at the gateway (or, with `--center`, at the burn center's server).

Run on the machine itself, as whoever owns the database: these commands need no session and act as the gateway's
own command line in the audit trail (user none). A password is typed twice without echo, or read as one line from
standard input with --password-stdin (for scripts); never given on the command line.
"""

from __future__ import annotations

import argparse
import getpass
import json
import sys
from collections.abc import Callable

import msgspec

from burnedge.cli_help import examples
from burnedge.cli_sync import site_database
from schemas.accounts import PasswordReset, Role, UserCreate
from schemas.config import Config
from schemas.errors import InvalidInput

RULES = f"usernames: lower-case letters, digits . _ -; passwords: 10+ characters; roles: {', '.join(Role)}"


def read_password(from_stdin: bool) -> str:
    if from_stdin:
        return sys.stdin.readline().rstrip("\n")
    first = getpass.getpass("New password: ")
    if getpass.getpass("The same again: ") != first:
        raise InvalidInput("the two passwords differ: nothing was changed")
    return first


def _valid(struct: type, fields: dict):
    try:
        return msgspec.convert(fields, struct)
    except msgspec.ValidationError as exc:
        raise InvalidInput(f"{exc} ({RULES})") from exc


def _print(value) -> None:
    print(json.dumps(msgspec.to_builtins(value), indent=2))


def _accounts(db, config: Config):
    from base.accounts.service import AccountService

    return AccountService(db, config.security)


def cmd_users_add(args, config: Config) -> int:
    password = read_password(args.password_stdin)
    body = _valid(
        UserCreate,
        {"username": args.username, "password": password, "role": args.role, "display_name": args.name or ""},
    )
    with site_database(config, args.center) as db:
        user = _accounts(db, config).create_user(None, body)
    print(json.dumps({"id": user.id, "username": user.username, "role": user.role.value}))
    return 0


def cmd_users_list(args, config: Config) -> int:
    with site_database(config, args.center) as db:
        _print(_accounts(db, config).list_users(None))
    return 0


def cmd_users_passwd(args, config: Config) -> int:
    with site_database(config, args.center) as db:
        accounts = _accounts(db, config)
        user = accounts.user_named(args.username)  # before the password is typed: a wrong name fails at once
        password = _valid(PasswordReset, {"password": read_password(args.password_stdin)}).password
        _print(accounts.reset_password(None, user.id, password, temporary=args.temporary))
    return 0


def cmd_users_disable(args, config: Config) -> int:
    with site_database(config, args.center) as db:
        accounts = _accounts(db, config)
        _print(accounts.set_active(None, accounts.user_named(args.username).id, False))
    return 0


def cmd_users_enable(args, config: Config) -> int:
    with site_database(config, args.center) as db:
        accounts = _accounts(db, config)
        _print(accounts.set_active(None, accounts.user_named(args.username).id, True))
    return 0


def add_commands(sub, load: Callable[[argparse.Namespace], Config]) -> None:
    def bind(parser, func) -> None:
        parser.add_argument(
            "--center", action="store_true", help="act on the burn center's accounts ([central] database; consultants)"
        )
        parser.set_defaults(func=lambda args: func(args, load(args)))

    def stdin_flag(parser) -> None:
        parser.add_argument(
            "--password-stdin",
            action="store_true",
            help="read the password as one line from standard input instead of asking twice",
        )

    users = sub.add_parser(
        "users",
        help="manage user accounts",
        **examples(
            "burnedge users add --username admin --role admin",
            "burnedge users list",
            "burnedge users passwd amani.k --temporary",
            "burnedge users disable amani.k",
        ),
    )
    users = users.add_subparsers(dest="users_cmd", required=True)

    add = users.add_parser(
        "add",
        help="create an account (the first administrator, say)",
        **examples(
            "burnedge users add --username admin --role admin",
            "burnedge users add --username amani.k --role clinician --name 'Dr Amani K.'",
            "printf '%s\\n' \"$PASSWORD\" | burnedge users add --username dr.o --role consultant --password-stdin --center",
        ),
    )
    add.add_argument("--username", required=True, help="lower-case letters, digits . _ -, e.g. amani.k")
    add.add_argument("--role", required=True, choices=[r.value for r in Role])
    add.add_argument("--name", help="display name")
    stdin_flag(add)
    bind(add, cmd_users_add)

    listing = users.add_parser(
        "list",
        help="every account: role, active or disabled, whether a password change is due",
        **examples("burnedge users list", "burnedge users list --center"),
    )
    bind(listing, cmd_users_list)

    passwd = users.add_parser(
        "passwd",
        help="set an account's password; its sessions end at once",
        **examples(
            "burnedge users passwd amani.k",
            "burnedge users passwd amani.k --temporary   # they choose their own at next sign-in",
            "printf '%s\\n' \"$PASSWORD\" | burnedge users passwd admin --password-stdin",
        ),
    )
    passwd.add_argument("username", metavar="USERNAME")
    passwd.add_argument(
        "--temporary",
        action="store_true",
        help="the user must change it at next sign-in (POST /api/v1/auth/password) before anything "
        "else; without it the password stays theirs until changed",
    )
    stdin_flag(passwd)
    bind(passwd, cmd_users_passwd)

    disable = users.add_parser(
        "disable",
        help="disable an account: its sessions end at once, it cannot log in (the last active administrator stays)",
        **examples("burnedge users disable amani.k"),
    )
    disable.add_argument("username", metavar="USERNAME")
    bind(disable, cmd_users_disable)

    enable = users.add_parser(
        "enable", help="let a disabled account log in again", **examples("burnedge users enable amani.k")
    )
    enable.add_argument("username", metavar="USERNAME")
    bind(enable, cmd_users_enable)
