"""The clinic's durable outbox: case bundles sealed once, kept as encrypted chunk files and a row in SQLite.

A bundle is sealed when it is queued, so every re-send after a drop or a restart carries the same chunks and the
center can resume from what it holds. The chunk files are written and synced before the row is committed: a row
never points at chunks that are not on disk. Only the center's signed receipt marks a bundle delivered.
"""

from __future__ import annotations

import hashlib
import logging
import shutil
import sqlite3
import threading
import uuid

import msgspec

from base.folders import outbox_root
from base.storage import audit
from base.storage.database import Database
from base.storage.durable import fsync_dir, write_file
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.errors import Conflict, NotFound
from schemas.transfer import PROTOCOL, OutboxEntry, OutboxState, SignedEnvelope, TransferManifest
from sync import bundle, case_snapshot, peers
from sync.keys import SiteKeys
from sync.sealing import seal

log = logging.getLogger("burnedge.sync")
_envelope = msgspec.msgpack.Decoder(SignedEnvelope)
_queue_lock = threading.Lock()


class Outbox:
    def __init__(self, db: Database, config: Config):
        self.db = db
        self.config = config
        self.root = outbox_root(config)

    def queue(self, keys: SiteKeys, encounter_id: str, user: str) -> OutboxEntry:
        """Seal the encounter as it stands now and queue it; a repeat with nothing changed returns the last one."""
        with _queue_lock:  # one bundle version at a time per gateway: versions are counted, not raced
            with self.db.read() as conn:
                center = peers.only_center(conn, self.config.sync.center_id)
                snap = case_snapshot.snapshot(conn, self.config, encounter_id)
                digest = _content_digest(snap.parts)
                last = conn.execute(
                    "SELECT * FROM outbox WHERE center_id = ? AND encounter_id = ? ORDER BY version DESC LIMIT 1",
                    (center.site_id, encounter_id),
                ).fetchone()
            if last is not None and last["content_digest"] == digest:
                return msgspec.structs.replace(_entry(last), unchanged=True)
            version = 1 if last is None else last["version"] + 1
            bundle_id = str(uuid.uuid4())
            manifest = case_snapshot.manifest_for(
                snap,
                bundle_id=bundle_id,
                site_id=keys.site_id,
                version=version,
                supersedes=last["bundle_id"] if last else None,
                created_by=user,
            )
            sealed = seal(
                bundle.pack(manifest, snap.parts),
                bytes.fromhex(center.box_key),
                bundle_id,
                self.config.sync.chunk_kib * 1024,
            )
            announcement = TransferManifest(
                protocol=PROTOCOL,
                bundle_id=bundle_id,
                site_id=keys.site_id,
                center_id=center.site_id,
                encounter_id=encounter_id,
                version=version,
                created_at=manifest.created_at,
                sealed_key=sealed.sealed_key,
                plain_size=sum(p.size for p in manifest.parts),
                chunks=sealed.refs,
            )
            envelope = keys.sign("manifest", announcement)
            self._write_chunks(bundle_id, sealed.chunks)
            try:
                with self.db.write() as conn:
                    conn.execute(
                        "INSERT INTO outbox (bundle_id, encounter_id, version, center_id, content_digest, state,"
                        " envelope, chunks, bytes, created_at, created_by) VALUES (?,?,?,?,?,?,?,?,?,?,?)",
                        (
                            bundle_id,
                            encounter_id,
                            version,
                            center.site_id,
                            digest,
                            OutboxState.queued.value,
                            msgspec.msgpack.encode(envelope),
                            len(sealed.chunks),
                            sum(len(c) for c in sealed.chunks),
                            manifest.created_at,
                            user,
                        ),
                    )
                    audit.append(
                        conn,
                        action="sync.queue",
                        user_id=None,
                        device_id=None,
                        kind="encounter",
                        record_id=encounter_id,
                        detail=f"bundle {bundle_id} version {version} for "
                        f"{center.site_id} ({len(manifest.parts)} parts), by {user}",
                    )
            except sqlite3.IntegrityError as exc:
                shutil.rmtree(self.root / bundle_id, ignore_errors=True)
                raise Conflict(f"version {version} of encounter {encounter_id} was queued meanwhile") from exc
            except BaseException:
                shutil.rmtree(self.root / bundle_id, ignore_errors=True)
                raise
        log.info(
            "queued bundle %s (encounter %s, version %d, %d chunks)",
            bundle_id,
            encounter_id,
            version,
            len(sealed.chunks),
        )
        return self.get(bundle_id)

    def get(self, bundle_id: str) -> OutboxEntry:
        row = self.db.connection().execute("SELECT * FROM outbox WHERE bundle_id = ?", (bundle_id,)).fetchone()
        if row is None:
            raise NotFound(f"no bundle {bundle_id} in the outbox")
        return _entry(row)

    def entries(self, encounter_id: str | None = None, limit: int = 200) -> list[OutboxEntry]:
        sql, params = "SELECT * FROM outbox", []
        if encounter_id is not None:
            sql, params = sql + " WHERE encounter_id = ?", [encounter_id]
        rows = self.db.connection().execute(sql + " ORDER BY created_at DESC LIMIT ?", [*params, limit])
        return [_entry(r) for r in rows]

    def pending(self) -> list[sqlite3.Row]:
        """Bundles still to deliver, oldest first (the center sees each clinic's versions in order)."""
        return (
            self.db.connection()
            .execute("SELECT * FROM outbox WHERE state = ? ORDER BY created_at, version", (OutboxState.queued.value,))
            .fetchall()
        )

    def envelope(self, row: sqlite3.Row) -> SignedEnvelope:
        return _envelope.decode(row["envelope"])

    def chunk(self, bundle_id: str, index: int) -> bytes:
        return (self.root / bundle_id / f"{index:06d}.chunk").read_bytes()

    def progress(self, bundle_id: str, sent_chunks: int) -> None:
        with self.db.write() as conn:
            conn.execute(
                "UPDATE outbox SET sent_chunks = MAX(sent_chunks, ?) WHERE bundle_id = ?", (sent_chunks, bundle_id)
            )

    def failed_attempt(self, bundle_id: str, error: str) -> None:
        with self.db.write() as conn:
            conn.execute(
                "UPDATE outbox SET attempts = attempts + 1, last_error = ? WHERE bundle_id = ?", (error, bundle_id)
            )

    def delivered(self, bundle_id: str, receipt: SignedEnvelope) -> None:
        with self.db.write() as conn:
            row = conn.execute("SELECT * FROM outbox WHERE bundle_id = ?", (bundle_id,)).fetchone()
            if row["state"] == OutboxState.delivered.value:
                return
            conn.execute(
                "UPDATE outbox SET state = ?, delivered_at = ?, receipt = ?, sent_chunks = chunks,"
                " last_error = NULL WHERE bundle_id = ?",
                (OutboxState.delivered.value, iso(utcnow()), msgspec.msgpack.encode(receipt), bundle_id),
            )
            audit.append(
                conn,
                action="sync.delivered",
                user_id=None,
                device_id=None,
                kind="encounter",
                record_id=row["encounter_id"],
                detail=f"bundle {bundle_id} version {row['version']} stored by {row['center_id']}",
            )
        shutil.rmtree(self.root / bundle_id, ignore_errors=True)  # the center holds it now

    def _write_chunks(self, bundle_id: str, chunks: list[bytes]) -> None:
        folder = self.root / bundle_id
        folder.mkdir(parents=True, exist_ok=False)
        for index, data in enumerate(chunks):
            write_file(folder / f"{index:06d}.chunk", data)
        for path in (folder, self.root):
            fsync_dir(path)


def _content_digest(parts: list[bundle.PartData]) -> str:
    described = [(p.name, p.described.sha256) for p in parts]
    return hashlib.sha256(msgspec.json.encode(described)).hexdigest()


def _entry(row: sqlite3.Row) -> OutboxEntry:
    return OutboxEntry(
        bundle_id=row["bundle_id"],
        encounter_id=row["encounter_id"],
        version=row["version"],
        center_id=row["center_id"],
        state=OutboxState(row["state"]),
        chunks=row["chunks"],
        sent_chunks=row["sent_chunks"],
        bytes=row["bytes"],
        created_at=row["created_at"],
        created_by=row["created_by"],
        attempts=row["attempts"],
        last_error=row["last_error"],
        delivered_at=row["delivered_at"],
    )
