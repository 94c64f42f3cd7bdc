"""The clinic's durable outbox: case bundles sealed once, kept as encrypted chunk files and a row in SQLite.

A bundle is sealed when it is queued, so every re-send after a drop or a restart carries the same chunks and the
center can resume from what it holds. The chunk files are written and synced before the row is committed: a row
never points at chunks that are not on disk. Only the center's signed receipt marks a bundle delivered.
"""

from __future__ import annotations

import hashlib
import logging
import os
import shutil
import threading
import uuid
from collections.abc import Callable, Iterable

import msgspec

from base.folders import outbox_root
from base.storage import audit
from base.storage.database import Database
from base.storage.durable import fsync_dir
from schemas.base import iso, utcnow
from schemas.config import Config
from schemas.encounter_snapshot import EncounterSnapshot
from schemas.errors import Conflict, DuplicateRow
from schemas.transfer import (
    PROTOCOL,
    ChunkRef,
    OutboxBundle,
    OutboxEntry,
    OutboxState,
    SignedEnvelope,
    SiteIdentity,
    TransferManifest,
)
from sync import bundle, case_snapshot, peers
from sync.keys import SiteKeys
from sync.sealing import seal_stream
from sync.storage import outbox as store

log = logging.getLogger("burnedge.sync")
_envelope = msgspec.msgpack.Decoder(SignedEnvelope)
SEALED_FILE = "sealed.bin"
"""A queued bundle's encrypted chunks, one after the other."""
_queue_lock = threading.Lock()


class Outbox:
    def __init__(self, db: Database, config: Config):
        self.db = db
        self.config = config
        self.root = outbox_root(config)

    def preview(self, read: EncounterSnapshot) -> tuple[SiteIdentity, list[bundle.PartData]]:
        """The center a case would go to and the parts it would carry now, as `read` reads the encounter (before
        the report and the healing are made, which go with it): what the clinician confirms before sending."""
        with self.db.read() as conn:
            center = peers.only_center(conn, self.config.sync.center_id)
            return center, case_snapshot.snapshot(conn, self.config, read).parts

    def queue(
        self,
        keys: SiteKeys,
        encounter: Callable[[], EncounterSnapshot],
        user: str,
        extra: Callable[[EncounterSnapshot], tuple[bundle.PartData, ...]] = lambda _: (),
    ) -> OutboxEntry:
        """Seal the encounter as `encounter()` reads it now and queue it; a repeat with nothing changed returns the
        last one. `extra`: the parts made from the same reading that travel with it (the clinical report, the
        wounds' healing). Read under the queue's lock, so a later version never carries an earlier reading."""
        with _queue_lock:  # one bundle version at a time per gateway: versions are counted, not raced
            read = encounter()
            made = extra(read)
            encounter_id = read.encounter.value.id
            with self.db.read() as conn:
                center = peers.only_center(conn, self.config.sync.center_id)
                snap = case_snapshot.snapshot(conn, self.config, read, made)
                # Derived parts (the report) change with the clock and the center's own notes: only the record
                # and its files decide whether the case changed.
                derived = {part.name for part in made}
                digest = _content_digest([part for part in snap.parts if part.name not in derived])
                last = store.latest(conn, center.site_id, encounter_id)
            if last is not None and last.content_digest == digest:
                return msgspec.structs.replace(last.entry, unchanged=True)
            version = 1 if last is None else last.entry.version + 1
            bundle_id = str(uuid.uuid4())
            manifest = case_snapshot.manifest_for(
                snap,
                bundle_id=bundle_id,
                site_id=keys.site_id,
                version=version,
                supersedes=last.entry.bundle_id if last else None,
                created_by=user,
            )
            total, pieces = bundle.packed(manifest, snap.parts)
            sealed_key, chunks = seal_stream(
                pieces, total, bytes.fromhex(center.box_key), bundle_id, self.config.sync.chunk_kib * 1024
            )
            refs = self._write_chunks(bundle_id, chunks)  # sealed a chunk at a time, straight into the file
            announcement = TransferManifest(
                protocol=PROTOCOL,
                bundle_id=bundle_id,
                site_id=keys.site_id,
                center_id=center.site_id,
                encounter_id=encounter_id,
                version=version,
                created_at=manifest.created_at,
                sealed_key=sealed_key,
                plain_size=sum(p.size for p in manifest.parts),
                chunks=refs,
            )
            envelope = keys.sign("manifest", announcement)
            try:
                with self.db.write() as conn:
                    store.insert_queued(
                        conn,
                        bundle_id=bundle_id,
                        encounter_id=encounter_id,
                        version=version,
                        center_id=center.site_id,
                        content_digest=digest,
                        envelope=msgspec.msgpack.encode(envelope),
                        chunks=len(refs),
                        size=sum(r.size for r in refs),
                        created_at=manifest.created_at,
                        created_by=user,
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
            except DuplicateRow as exc:
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
            len(refs),
        )
        return self.get(bundle_id)

    def get(self, bundle_id: str) -> OutboxEntry:
        return store.get(self.db.connection(), bundle_id).entry

    def entries(self, encounter_id: str | None = None, limit: int = 200) -> list[OutboxEntry]:
        return store.entries(self.db.connection(), encounter_id, limit)

    def pending(self) -> list[OutboxBundle]:
        """Bundles still to deliver, oldest first (the center sees each clinic's versions in order)."""
        return store.pending(self.db.connection())

    def envelope(self, queued: OutboxBundle) -> SignedEnvelope:
        return _envelope.decode(queued.envelope)

    def chunk(self, bundle_id: str, index: int, refs: list[ChunkRef]) -> bytes:
        """Chunk `index` of the bundle's sealed file (one file per bundle; a bundle queued by an older gateway has
        a file per chunk)."""
        folder = self.root / bundle_id
        try:
            with open(folder / SEALED_FILE, "rb") as sealed:
                sealed.seek(index * refs[0].size)  # every chunk but the last is the same size
                return sealed.read(refs[index].size)
        except FileNotFoundError:
            return (folder / f"{index:06d}.chunk").read_bytes()

    def progress(self, bundle_id: str, sent_chunks: int) -> None:
        with self.db.write() as conn:
            store.record_progress(conn, bundle_id, sent_chunks)

    def failed_attempt(self, bundle_id: str, error: str) -> None:
        with self.db.write() as conn:
            store.record_failed_attempt(conn, bundle_id, error)

    def delivered(self, bundle_id: str, receipt: SignedEnvelope) -> None:
        with self.db.write() as conn:
            entry = store.get(conn, bundle_id).entry
            if entry.state is OutboxState.delivered:
                return
            store.mark_delivered(conn, bundle_id, iso(utcnow()), msgspec.msgpack.encode(receipt))
            audit.append(
                conn,
                action="sync.delivered",
                user_id=None,
                device_id=None,
                kind="encounter",
                record_id=entry.encounter_id,
                detail=f"bundle {bundle_id} version {entry.version} stored by {entry.center_id}",
            )
        shutil.rmtree(self.root / bundle_id, ignore_errors=True)  # the center holds it now

    def _write_chunks(self, bundle_id: str, chunks: Iterable[bytes]) -> list[ChunkRef]:
        """The sealed chunks into the bundle's one file, with one fsync (a file per chunk cost an fsync each:
        1,600 for 200 MB); each chunk's name (its sha256) and size, for the announcement."""
        folder = self.root / bundle_id
        folder.mkdir(parents=True, exist_ok=False)
        refs = []
        try:
            with open(folder / SEALED_FILE, "xb") as sealed:
                for data in chunks:
                    sealed.write(data)
                    refs.append(ChunkRef(sha256=hashlib.sha256(data).hexdigest(), size=len(data)))
                sealed.flush()
                os.fsync(sealed.fileno())
            for path in (folder, self.root):
                fsync_dir(path)
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            raise
        return refs


def _content_digest(parts: list[bundle.PartData]) -> str:
    described = [(p.name, p.described.sha256) for p in parts]
    return hashlib.sha256(msgspec.json.encode(described)).hexdigest()
