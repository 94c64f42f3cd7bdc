"""`burnedge keys`, `burnedge peers`, `burnedge sync` and `burnedge central`: store-and-forward to the burn center.

`--center` makes keys, peers and users act on the burn center's files ([central] in the config) instead of the
clinic gateway's.
"""

from __future__ import annotations

import argparse
import json
import logging
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

import msgspec

from base import folders
from burnedge.cli_help import examples
from gateway.storage.database import Database
from schemas.config import Config
from schemas.errors import InvalidInput
from schemas.transfer import SiteIdentity, SiteRole

log = logging.getLogger("burnedge")


def _keys_dir(config: Config, center: bool) -> Path:
    return folders.center_keys_dir(config.central) if center else folders.keys_dir(config)


@contextmanager
def site_database(config: Config, center: bool):
    """The clinic gateway's database, or with `center` the burn center's; migrated, closed after."""
    if center:
        from center.app import open_center_db

        db = open_center_db(config.central)
    else:
        db = Database.from_config(config.gateway)
        db.migrate()
    try:
        yield db
    finally:
        db.close()


def _print(value) -> None:
    print(json.dumps(msgspec.to_builtins(value), indent=2))


def cmd_keys_init(args, config: Config) -> int:
    from sync.keys import fingerprint, init_keys

    role = SiteRole.center if args.center else SiteRole.clinic
    keys = init_keys(_keys_dir(config, args.center), args.site_id, role, args.name, force=args.force)
    _print(
        {
            "site_id": keys.site_id,
            "role": role.value,
            "fingerprint": fingerprint(keys.identity),
            "public_file": str(_keys_dir(config, args.center) / "site.pub.json"),
        }
    )
    return 0


def cmd_keys_show(args, config: Config) -> int:
    from sync.keys import fingerprint, load_keys

    keys = load_keys(_keys_dir(config, args.center))
    _print({"identity": keys.identity, "fingerprint": fingerprint(keys.identity)})
    return 0


def cmd_peers_enrol(args, config: Config) -> int:
    from sync import peers

    try:
        identity = msgspec.json.decode(Path(args.file).read_bytes(), type=SiteIdentity)
    except (OSError, msgspec.DecodeError, msgspec.ValidationError) as exc:
        raise InvalidInput(f"{args.file} is not a site's public keys file (site.pub.json): {exc}") from exc
    wanted = SiteRole.clinic if args.center else SiteRole.center
    if identity.role is not wanted:
        raise InvalidInput(f"{args.file} holds the keys of a {identity.role.value}; here a {wanted.value} is enrolled")
    with site_database(config, args.center) as db:
        peer = peers.enrol(db, identity, by=args.by, replace=args.replace)
    _print(
        {
            "enrolled": peer.identity.site_id,
            "name": peer.identity.name,
            "fingerprint": peer.fingerprint,
            "check": "read this fingerprint to the site over the phone; it must match their `burnedge keys show`",
        }
    )
    return 0


def cmd_peers_revoke(args, config: Config) -> int:
    from sync import peers

    with site_database(config, args.center) as db:
        _print(peers.revoke(db, args.site_id, reason=args.reason, by=args.by))
    return 0


def cmd_peers_accept_restore(args, config: Config) -> int:
    from center.anchors import accept_restore

    if not args.center:
        raise InvalidInput("accept-restore acts on the burn center's files: add --center")
    with site_database(config, True) as db:
        _print(accept_restore(db, args.site_id, by=args.by, reason=args.reason))
    return 0


def cmd_peers_list(args, config: Config) -> int:
    from sync import peers

    with site_database(config, args.center) as db:
        _print(peers.list_peers(db))
    return 0


def cmd_sync_status(args, config: Config) -> int:
    from sync.service import SyncService

    with site_database(config, False) as db:
        service = SyncService(db, config)
        _print({"status": service.status(), "outbox": service.outbox.entries(limit=20)})
    return 0


def cmd_sync_now(args, config: Config) -> int:
    from sync.service import SyncService

    with site_database(config, False) as db:
        report = SyncService(db, config).run_round(force=True)
    _print(
        {"delivered": report.delivered, "rejected": report.rejected, "notes_received": report.notes_received}
        if report
        else {"skipped": "a round is already running"}
    )
    return 0


def cmd_sync_send(args, config: Config) -> int:
    from gateway.dependencies import Services

    with site_database(config, False) as db:
        _print(Services.build(config, db).transfers.send_from_console(args.encounter_id, args.by))
    return 0


def cmd_central(args, config: Config) -> int:
    from center.app import serve_central
    from sync.keys import PRIVATE_FILE, fingerprint, init_keys

    central = config.central
    overrides = {k: v for k, v in {"host": args.host, "port": args.port, "listen_endpoints": args.listen}.items() if v}
    config = msgspec.structs.replace(config, central=msgspec.structs.replace(central, **overrides))
    keys_dir = folders.center_keys_dir(config.central)
    if not (keys_dir / PRIVATE_FILE).exists():
        keys = init_keys(keys_dir, args.site_id, SiteRole.center, args.name)
        log.info(
            "made the center's keys in %s: fingerprint %s; give %s to each clinic",
            keys_dir,
            fingerprint(keys.identity),
            keys_dir / "site.pub.json",
        )
    serve_central(config)
    return 0


def cmd_central_router(args, config: Config) -> int:
    from center.router import serve_router

    central = config.central
    if args.listen:
        central = msgspec.structs.replace(central, listen_endpoints=args.listen)
    serve_router(central)
    return 0


def add_commands(sub, load: Callable[[argparse.Namespace], Config]) -> None:
    def bind(parser, func) -> None:
        parser.set_defaults(func=lambda args: func(args, load(args)))

    def center_flag(parser) -> None:
        parser.add_argument("--center", action="store_true", help="act on the burn center's files ([central])")

    keys = sub.add_parser(
        "keys",
        help="this site's encryption and signing keys",
        **examples("burnedge keys init --site-id clinic-kasese --name 'Kasese clinic'", "burnedge keys show"),
    ).add_subparsers(dest="keys_cmd", required=True)
    init = keys.add_parser(
        "init",
        help="make this site's keys (once; peers enrol the public half)",
        **examples(
            "burnedge keys init --site-id clinic-kasese --name 'Kasese clinic'",
            "burnedge keys init --site-id burn-center --name 'Mulago burn unit' --center",
        ),
    )
    init.add_argument("--site-id", required=True, help="lower-case name on the wire, e.g. clinic-kasese")
    init.add_argument("--name", required=True, help="what people call the site")
    init.add_argument("--force", action="store_true", help="replace existing keys (every peer must enrol again)")
    center_flag(init)
    bind(init, cmd_keys_init)
    show = keys.add_parser(
        "show",
        help="this site's public keys and fingerprint",
        **examples("burnedge keys show", "burnedge keys show --center"),
    )
    center_flag(show)
    bind(show, cmd_keys_show)

    peers = sub.add_parser(
        "peers", help="sites this one trusts", **examples("burnedge peers enrol center.pub.json", "burnedge peers list")
    ).add_subparsers(dest="peers_cmd", required=True)
    enrol = peers.add_parser(
        "enrol",
        help="trust a site's public keys file (site.pub.json); shows its fingerprint",
        **examples(
            "burnedge peers enrol center.pub.json --by amani.k",
            "burnedge peers enrol clinic-kasese.pub.json --center --replace",
        ),
    )
    enrol.add_argument("file", metavar="FILE", help="the other site's site.pub.json (from its `burnedge keys init`)")
    enrol.add_argument("--by", default="cli", help="who enrols it (audited)")
    enrol.add_argument("--replace", action="store_true", help="replace the keys of a site enrolled before")
    center_flag(enrol)
    bind(enrol, cmd_peers_enrol)
    revoke = peers.add_parser(
        "revoke",
        help="stop trusting a site: what it sends from now on is rejected",
        **examples("burnedge peers revoke clinic-kasese --center --reason 'laptop stolen' --by it.desk"),
    )
    revoke.add_argument("site_id", metavar="SITE_ID")
    revoke.add_argument("--reason", required=True, help="why, for the audit trail (e.g. 'laptop stolen')")
    revoke.add_argument("--by", default="cli", help="who revokes it (audited)")
    center_flag(revoke)
    bind(revoke, cmd_peers_revoke)
    accept = peers.add_parser(
        "accept-restore",
        help="at the center: a clinic was restored from a backup on purpose; "
        "void its audit anchors so its restored chain is anchored afresh",
        **examples(
            "burnedge peers accept-restore clinic-kasese --center --reason 'disk failed; restored "
            "the backup of 2026-12-01' --by it.desk"
        ),
    )
    accept.add_argument("site_id", metavar="SITE_ID")
    accept.add_argument("--reason", required=True, help="e.g. 'disk failed; restored the backup of 2026-12-01'")
    accept.add_argument("--by", default="cli", help="who accepts it (audited)")
    center_flag(accept)
    bind(accept, cmd_peers_accept_restore)
    listing = peers.add_parser(
        "list",
        help="enrolled sites with fingerprints and revocations",
        **examples("burnedge peers list", "burnedge peers list --center"),
    )
    center_flag(listing)
    bind(listing, cmd_peers_list)

    sync = sub.add_parser(
        "sync", help="the clinic's link to the burn center", **examples("burnedge sync status", "burnedge sync now")
    ).add_subparsers(dest="sync_cmd", required=True)
    bind(
        sync.add_parser(
            "status", help="last round, errors, backoff and the outbox", **examples("burnedge sync status")
        ),
        cmd_sync_status,
    )
    bind(
        sync.add_parser(
            "now", help="run one round now: deliver queued cases, fetch advice", **examples("burnedge sync now")
        ),
        cmd_sync_now,
    )
    send = sync.add_parser(
        "send",
        help="queue an encounter for the burn center as it stands now",
        **examples("burnedge sync send 0192f3b4-6a8e-7c3d-9b1a-2f4e5d6c7b8a --by 'Dr Amani K.'"),
    )
    send.add_argument("encounter_id", metavar="ENCOUNTER_ID")
    send.add_argument("--by", required=True, help="the clinician sending it (audited)")
    bind(send, cmd_sync_send)

    central = sub.add_parser(
        "central",
        help="run the burn center's server: the Zenoh endpoint clinics connect to "
        "and the consultants' HTTP API (keys made on first start)",
        **examples(
            "burnedge central",
            "burnedge central --listen tcp/0.0.0.0:7447 --host 0.0.0.0 "
            "--port 8090 --site-id burn-center --name 'Mulago burn unit'",
        ),
    )
    central.add_argument("--host", help="address of the consultants' API")
    central.add_argument("--port", type=int, help="port of the consultants' API")
    central.add_argument("--listen", action="append", metavar="ENDPOINT", help="Zenoh endpoint, e.g. tcp/0.0.0.0:7447")
    central.add_argument("--site-id", default="burn-center", help="the center's id when its keys are first made")
    central.add_argument("--name", default="Burn center", help="the center's name when its keys are first made")
    bind(central, cmd_central)
    router = central.add_subparsers(dest="central_command", metavar="router").add_parser(
        "router",
        help="run the center's Zenoh router on its own: clinics and several center workers connect to it",
        **examples(
            "burnedge central router --listen tcp/0.0.0.0:7447",
            "burnedge central router --listen tcp/0.0.0.0:7447 --listen tcp/127.0.0.1:7448",
        ),
    )
    router.add_argument("--listen", action="append", metavar="ENDPOINT", help="Zenoh endpoint, e.g. tcp/0.0.0.0:7447")
    bind(router, cmd_central_router)
