"""`burnedge backup`, `burnedge backup keygen` and `burnedge restore`: the gateway's whole state, encrypted.

A passphrase comes from a file, an environment variable or a prompt, never from the command line itself (it would
be in the shell history and in every process listing).
"""

from __future__ import annotations

import argparse
import getpass
import json
import os
import sys
from collections.abc import Callable
from pathlib import Path

import msgspec

from burnedge.cli_help import examples
from gateway.backup.crypto import FileKey
from schemas.backup import BackupHeader
from schemas.config import Config
from schemas.errors import InvalidInput, NotFound


def _passphrase(args, config: Config | None, *, confirm: bool) -> str:
    file = args.passphrase_file or (config.backup.passphrase_file if config else "")
    if args.passphrase_env:
        value = os.environ.get(args.passphrase_env)
        if not value:
            raise InvalidInput(f"the environment variable {args.passphrase_env} is not set or empty")
        return value
    if file:
        try:
            text = Path(file).read_text(encoding="utf-8")
        except FileNotFoundError as exc:
            raise NotFound(f"no passphrase file {file}") from exc
        except (OSError, UnicodeDecodeError) as exc:
            raise InvalidInput(f"cannot read the passphrase file {file}: {exc}") from exc
        value = text[:-1] if text.endswith("\n") else text
        value = value[:-1] if value.endswith("\r") else value
        if not value:
            raise InvalidInput(f"the passphrase file {file} is empty")
        return value
    if not sys.stdin.isatty():
        raise InvalidInput(
            "no passphrase: give --passphrase-file FILE or --passphrase-env NAME (or --recipient / "
            "--identity for a key), or run this at a terminal to be asked"
        )
    value = getpass.getpass("Backup passphrase: ")
    if confirm and getpass.getpass("Again: ") != value:
        raise InvalidInput("the two passphrases differ; nothing was written")
    return value


def _encryption(args, config: Config):
    from gateway.backup import crypto
    from gateway.backup.writer import Encryption

    recipient = args.recipient or config.backup.recipient
    if recipient and (args.passphrase_file or args.passphrase_env):
        raise InvalidInput("give a recipient key or a passphrase, not both")
    if recipient:
        key, sealed = crypto.new_recipient_key(Path(recipient))
        return Encryption(key=key, recipient=sealed)
    passphrase = _passphrase(args, config, confirm=True)
    key, kdf = crypto.new_passphrase_key(passphrase, config.backup.kdf_opslimit, config.backup.kdf_memory_kib * 1024)
    return Encryption(key=key, kdf=kdf)


def cmd_backup(args, config: Config) -> int:
    from gateway.backup import writer

    if args.out and args.dir:
        raise InvalidInput("give --out FILE or --dir DIR, not both")
    folder = args.dir or config.backup.folder
    if not args.out and not folder:
        raise InvalidInput(
            "where to? give --out FILE, or --dir DIR (or [backup] folder in the config) for rotated backups"
        )
    encryption = _encryption(args, config)
    removed: list[Path] = []
    if args.out:
        target = Path(args.out)
        if target.is_dir():
            raise InvalidInput(f"{target} is a folder: use --dir {target} for rotated backups, or name a file")
        manifest = writer.write_backup(config, target, encryption)
    else:
        keep = args.keep if args.keep is not None else config.backup.keep
        target, manifest, removed = writer.rotate(config, Path(folder), keep, encryption)
    _print(
        {
            "backup": str(target),
            "bytes": target.stat().st_size,
            "files": len(manifest.files),
            "mode": "recipient" if encryption.recipient else "passphrase",
            "created_at": manifest.created_at,
            "audit_head": manifest.audit_head,
            "skipped": manifest.skipped,
            "removed": [str(p) for p in removed],
        }
    )
    return 0


def cmd_keygen(args, config: Config) -> int:
    from gateway.backup.crypto import keygen

    public, private, fingerprint = keygen(Path(args.keygen_out))
    _print(
        {
            "public_key": str(public),
            "private_key": str(private),
            "fingerprint": fingerprint,
            "next": f"copy {public} to the gateway and set [backup] recipient to it; move {private} OFF the "
            "gateway (a USB stick in a safe, a second copy elsewhere): only it opens the backups",
        }
    )
    return 0


def _unlock(args) -> Callable[[BackupHeader], FileKey]:
    from gateway.backup import crypto

    def unlock(header: BackupHeader) -> FileKey:
        if header.mode == "recipient":
            if not args.identity:
                raise InvalidInput(
                    f"this backup is encrypted to recipient key {header.recipient.fingerprint}: "
                    "give --identity with its private key file (backup-recipient.key.json)"
                )
            return crypto.recipient_key(Path(args.identity), header.recipient)
        if header.kdf is None:
            raise InvalidInput("the backup's header names no key derivation; use another copy")
        return crypto.passphrase_key(_passphrase(args, None, confirm=False), header.kdf)

    return unlock


def cmd_restore(args, config: Config) -> int:
    from gateway.backup import restore

    if args.check:
        manifest, _, _ = restore.check(Path(args.file), _unlock(args))
        _print(
            {
                "checked": args.file,
                "ok": True,
                "files": len(manifest.files),
                "created_at": manifest.created_at,
                "audit_head": manifest.audit_head,
                "site_id": manifest.site_id,
                "skipped": manifest.skipped,
            }
        )
        return 0
    if not args.into:
        raise InvalidInput("give --into DIR (a new, empty folder), or --check to verify only")
    done = restore.restore(Path(args.file), Path(args.into), _unlock(args), force=args.force)
    _print(
        {
            "restored": str(done.into),
            "config": str(done.config),
            "database": str(done.database),
            "files": done.files,
            "bytes": done.bytes,
            "created_at": done.manifest.created_at,
            "site_id": done.manifest.site_id,
            "audit_head": done.manifest.audit_head,
            "skipped": done.manifest.skipped,
            "replaced": done.replaced,
            "next": f"burnedge --config {done.config} audit verify; then burnedge --config {done.config} serve",
        }
    )
    return 0


def _print(value) -> None:
    print(json.dumps(msgspec.to_builtins(value), indent=2))


def _key_options(parser, *, identity: bool) -> None:
    parser.add_argument("--passphrase-file", metavar="FILE", help="read the passphrase from FILE (first line)")
    parser.add_argument("--passphrase-env", metavar="NAME", help="read the passphrase from environment variable NAME")
    if identity:
        parser.add_argument("--identity", metavar="FILE", help="private key file of a recipient-key backup")
    else:
        parser.add_argument(
            "--recipient",
            metavar="FILE",
            help="encrypt to this public key file (`burnedge backup keygen`) instead of a passphrase",
        )


def add_commands(sub, load: Callable[[argparse.Namespace], Config]) -> None:
    def bind(parser, func) -> None:
        parser.set_defaults(func=lambda args: func(args, load(args)))

    backup = sub.add_parser(
        "backup",
        help="encrypted, consistent copy of the whole gateway state, while it serves",
        **examples(
            "burnedge backup --dir /mnt/backups --keep 14",
            "burnedge backup --out state.burnedge-backup --recipient backup-recipient.pub.json",
            "burnedge backup --out state.burnedge-backup --passphrase-file /root/passphrase",
            "BURNEDGE_PASSPHRASE=... burnedge backup --out x.burnedge-backup --passphrase-env BURNEDGE_PASSPHRASE",
            "burnedge backup keygen --out keys/",
        ),
    )
    backup.add_argument("--out", metavar="FILE", help="write the backup to FILE (replaced once the new one is whole)")
    backup.add_argument(
        "--dir",
        metavar="DIR",
        help="write a dated backup into DIR and keep the newest N there (default: [backup] folder)",
    )
    backup.add_argument("--keep", type=int, metavar="N", help="backups kept in DIR (default: [backup] keep)")
    _key_options(backup, identity=False)
    bind(backup, cmd_backup)
    backup_sub = backup.add_subparsers(dest="backup_cmd", metavar="SUBCOMMAND")
    keygen = backup_sub.add_parser(
        "keygen",
        help="make a recipient key pair; its private half goes off the gateway",
        **examples("burnedge backup keygen --out /media/usb"),
    )
    keygen.add_argument("--out", dest="keygen_out", required=True, metavar="DIR", help="folder for the two files")
    bind(keygen, cmd_keygen)

    restore = sub.add_parser(
        "restore",
        help="check a backup whole, then restore it into a new folder",
        **examples(
            "burnedge restore state.burnedge-backup --check --identity backup-recipient.key.json",
            "burnedge restore state.burnedge-backup --into /var/lib/burnedge-restored --identity backup-recipient.key.json",
            "burnedge restore state.burnedge-backup --into /var/lib/burnedge --force --passphrase-file passphrase.txt",
            "burnedge restore state.burnedge-backup --check --passphrase-env BURNEDGE_PASSPHRASE",
        ),
    )
    restore.add_argument("file", metavar="FILE", help="the backup file")
    restore.add_argument("--into", metavar="DIR", help="folder to restore into (new or empty)")
    restore.add_argument("--force", action="store_true", help="restore into a folder that is not empty")
    restore.add_argument("--check", action="store_true", help="only check the backup (every chunk and file)")
    _key_options(restore, identity=True)
    bind(restore, cmd_restore)
