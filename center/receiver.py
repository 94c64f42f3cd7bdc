"""The center's answers to clinics: announce, chunk, commit and mail, each checked before anything is kept.

Chunks are staged as files under their bundle until commit; a bundle is stored (part files, rows, receipt) in
one transaction after every part was decrypted and checked, so nothing partial is ever stored. Whatever a
clinic re-sends, each bundle version is stored once: a stored bundle is answered with its receipt again.

Several workers may share one PostgreSQL database and one store folder: any of them may take any message of a
transfer. The database's uniqueness constraints decide a race: the worker whose commit loses answers with the
winner's receipt.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import logging
import os
import shutil
import threading
from collections.abc import Callable
from pathlib import Path

import msgspec

from base.storage import audit
from base.storage.postgres import AnyDatabase
from center.sealed_bundles import SealedBundles, chunk_name
from center.storage import cases, notes, transfers
from schemas.base import iso, utcnow
from schemas.central import Announcement, RefusedBundle, SealedAtRest
from schemas.config import CentralConfig
from schemas.errors import DuplicateRow, TransferRejected
from schemas.transfer import (
    PROTOCOL,
    AnnounceReply,
    BundleManifest,
    CommitReply,
    MailRequest,
    Receipt,
    SignedEnvelope,
    SiteIdentity,
    SiteRole,
    TransferManifest,
)
from sync import bundle, peers
from sync.keys import SiteKeys, verify_envelope
from sync.sealing import OVERHEAD, open_chunks, unseal_key

log = logging.getLogger("burnedge.central")
_envelope = msgspec.msgpack.Decoder(SignedEnvelope)
_manifest = msgspec.msgpack.Decoder(TransferManifest)
MAIL_PAGE = 100


class Receiver:
    def __init__(self, db: AnyDatabase, config: CentralConfig, keys: SiteKeys, store_dir: Path):
        self.db = db
        self.config = config
        self.keys = keys
        self.staging = store_dir / "incoming"
        self.bundles = SealedBundles(store_dir / "bundles", keys.box)
        self._manifests: dict[tuple[str, str], TransferManifest] = {}
        self._locks: dict[tuple[str, str], threading.Lock] = {}
        self._locks_guard = threading.Lock()

    # announce ----------------------------------------------------------------------
    def announce(self, site_id: str, payload: bytes) -> AnnounceReply:
        envelope, identity = self.verified(site_id, payload, "manifest")
        manifest = _decode(_manifest, envelope.body, "manifest")
        self._check_manifest(site_id, manifest)
        conn = self.db.connection()
        receipt = cases.find_receipt(conn, site_id, manifest.bundle_id)
        if receipt is not None:
            log.info(
                "%s re-announced stored bundle %s: answered with its receipt, nothing stored again",
                site_id,
                manifest.bundle_id,
            )
            return AnnounceReply(status="stored", receipt=receipt)
        self._check_not_refused(conn, site_id, manifest.bundle_id)
        self._check_version(conn, site_id, manifest)
        body_sha = hashlib.sha256(envelope.body).hexdigest()
        with self.db.write() as conn:
            earlier = transfers.find_announcement(conn, site_id, manifest.bundle_id)
            if earlier is not None and earlier.manifest_sha256 != body_sha:
                raise TransferRejected(
                    f"bundle {manifest.bundle_id} was announced before with another manifest", code="manifest-conflict"
                )
            if earlier is None:
                transfers.insert_announcement(
                    conn,
                    Announcement(
                        site_id=site_id,
                        bundle_id=manifest.bundle_id,
                        envelope=payload,
                        manifest_sha256=body_sha,
                        encounter_id=manifest.encounter_id,
                        version=manifest.version,
                        chunks=len(manifest.chunks),
                        announced_at=iso(utcnow()),
                    ),
                )
        self._manifests[(site_id, manifest.bundle_id)] = manifest
        return AnnounceReply(status="send", held=self._held(site_id, manifest))

    # chunk --------------------------------------------------------------------------
    def chunk(self, site_id: str, bundle_id: str, index: int, sha256: str, payload: bytes) -> None:
        if (site_id, bundle_id) not in self._manifests and self._stored(site_id, bundle_id):
            return  # another worker committed the bundle while this chunk was on its way: nothing is missing
        manifest = self._incoming(site_id, bundle_id)
        if not 0 <= index < len(manifest.chunks):
            raise TransferRejected(f"bundle {bundle_id} has no chunk {index}", code="bad-chunk-index")
        ref = manifest.chunks[index]
        if sha256 != ref.sha256:
            raise TransferRejected(
                f"chunk {index} of {bundle_id} is named by another hash than its manifest lists", code="chunk-mismatch"
            )
        if len(payload) != ref.size:
            raise TransferRejected(
                f"chunk {index} of {bundle_id} has {len(payload)} bytes, its manifest says {ref.size} (truncated?)",
                code="chunk-size",
            )
        if hashlib.sha256(payload).hexdigest() != ref.sha256:
            raise TransferRejected(
                f"chunk {index} of {bundle_id} does not match its sha256 (altered on the way?)", code="chunk-mismatch"
            )
        folder = self.staging / site_id / bundle_id
        folder.mkdir(parents=True, exist_ok=True)
        tmp = folder / f"{index:06d}.{os.getpid()}-{threading.get_ident()}.tmp"
        tmp.write_bytes(payload)
        # Not synced: a chunk lost in a crash is reported missing at commit and sent again.
        os.replace(tmp, folder / chunk_name(index))

    # commit -------------------------------------------------------------------------
    def commit(self, site_id: str, bundle_id: str) -> CommitReply:
        with self._lock(site_id, bundle_id):
            stored = self._stored(site_id, bundle_id)
            if stored is not None:
                return CommitReply(status="stored", receipt=stored)
            try:
                return self._commit(site_id, bundle_id)
            except TransferRejected:
                stored = self._stored(site_id, bundle_id)
                if stored is None:
                    raise
                log.info("bundle %s from %s was stored by another worker meanwhile", bundle_id, site_id)
                return CommitReply(status="stored", receipt=stored)

    def _stored(self, site_id: str, bundle_id: str) -> SignedEnvelope | None:
        return cases.find_receipt(self.db.connection(), site_id, bundle_id)

    def _commit(self, site_id: str, bundle_id: str) -> CommitReply:
        transfer = self._incoming(site_id, bundle_id)
        folder = self.staging / site_id / bundle_id
        # Each chunk's sha256 was checked as it arrived; here only that it is still there and whole. Its
        # authentication tag, checked as it is decrypted, catches one damaged on disk since (unsynced at a crash).
        missing = [i for i, ref in enumerate(transfer.chunks) if not _size_ok(folder / chunk_name(i), ref.size)]
        if missing:
            stored = self._stored(site_id, bundle_id)  # another worker may have stored it and cleared the folder
            if stored is not None:
                return CommitReply(status="stored", receipt=stored)
            return CommitReply(status="missing", missing=missing)
        try:
            manifest, parts_offset = self._verify_and_keep(site_id, transfer, folder)
            receipt = self._store(site_id, transfer, manifest, parts_offset, folder)
        except _DamagedChunk as damaged:
            stored = self._stored(site_id, bundle_id)  # its staged chunks gone: another worker stored it
            if stored is not None:
                return CommitReply(status="stored", receipt=stored)
            (folder / chunk_name(damaged.index)).unlink(missing_ok=True)
            return CommitReply(status="missing", missing=[damaged.index])
        except TransferRejected as refused:
            self._refuse(site_id, bundle_id, refused)  # the bundle itself is bad: nothing of it is kept
            raise
        return CommitReply(status="stored", receipt=receipt)

    def _verify_and_keep(self, site_id: str, transfer: TransferManifest, folder: Path) -> tuple[BundleManifest, int]:
        """Check the bundle, decrypting one chunk at a time, while its chunks are written to the file it is kept
        in; that file on disk whole. The bundle's manifest, and where its parts start in its plaintext."""
        writer = self.bundles.writer(site_id, transfer.bundle_id)
        try:
            manifest, parts_offset = self._verify(site_id, transfer, folder, writer.write)
            writer.close_durably()
        except BaseException:
            writer.discard()
            raise
        return manifest, parts_offset

    def _verify(
        self, site_id: str, transfer: TransferManifest, folder: Path, keep: Callable[[bytes], None]
    ) -> tuple[BundleManifest, int]:
        key = unseal_key(transfer.sealed_key, self.keys.box)
        check = bundle.ContainerCheck()
        count = len(transfer.chunks)
        for index in range(count):
            data = _staged(folder / chunk_name(index))
            try:
                plain = next(open_chunks(key, transfer.bundle_id, [data], count, index))
            except TransferRejected:
                if hashlib.sha256(data).hexdigest() == transfer.chunks[index].sha256:
                    raise  # the clinic sent it so: the bundle itself is bad
                raise _DamagedChunk(index) from None
            check.feed(plain)
            keep(data)
        manifest, parts_offset = check.finish()
        if (manifest.bundle_id, manifest.site_id, manifest.encounter_id, manifest.version) != (
            transfer.bundle_id,
            site_id,
            transfer.encounter_id,
            transfer.version,
        ):
            raise TransferRejected("the bundle inside does not match its signed announcement", code="manifest-mismatch")
        return manifest, parts_offset

    def _store(
        self, site_id: str, transfer: TransferManifest, manifest: BundleManifest, parts_offset: int, folder: Path
    ) -> SignedEnvelope:
        count = len(transfer.chunks)
        announced = self._announcement(site_id, transfer.bundle_id)
        receipt = self.keys.sign(
            "receipt",
            Receipt(
                center_id=self.keys.site_id,
                site_id=site_id,
                bundle_id=transfer.bundle_id,
                version=transfer.version,
                manifest_sha256=announced.manifest_sha256,
                stored_at=iso(utcnow()),
                duplicate=False,
            ),
        )
        sealed = SealedAtRest(
            sealed_key=transfer.sealed_key,
            chunks=count,
            chunk_bytes=transfer.chunks[0].size,
            parts_offset=parts_offset,
        )
        try:
            self._insert(site_id, manifest, announced.manifest_sha256, receipt, sealed)
        except DuplicateRow as exc:  # commit() tells a worker's race (the same bundle) from a replay
            if self._stored(site_id, transfer.bundle_id) is None:
                self.bundles.forget(site_id, transfer.bundle_id)
            raise TransferRejected(
                f"version {manifest.version} of encounter {manifest.encounter_id} is already "
                "stored from another bundle: a replay",
                code="replayed",
            ) from exc
        shutil.rmtree(folder, ignore_errors=True)
        self._manifests.pop((site_id, manifest.bundle_id), None)
        log.info(
            "stored bundle %s from %s (encounter %s version %d, %d parts)",
            manifest.bundle_id,
            site_id,
            manifest.encounter_id,
            manifest.version,
            len(manifest.parts),
        )
        return receipt

    def _insert(
        self, site_id: str, manifest: BundleManifest, manifest_sha256: str, receipt: SignedEnvelope, sealed
    ) -> None:
        with self.db.write() as conn:
            cases.insert_bundle(
                conn,
                site_id,
                manifest,
                manifest_sha256=manifest_sha256,
                stored_at=iso(utcnow()),
                receipt=receipt,
                sealed=sealed,
            )
            transfers.delete_announcement(conn, site_id, manifest.bundle_id)
            audit.append(
                conn,
                action="bundle.store",
                user_id=None,
                device_id=None,
                kind="bundle",
                record_id=manifest.bundle_id,
                detail=f"from {site_id}: encounter {manifest.encounter_id} "
                f"version {manifest.version}, {len(manifest.parts)} parts, urgency "
                f"{manifest.summary.urgency.value}",
            )

    # mail ---------------------------------------------------------------------------
    def mail(self, site_id: str, payload: bytes) -> list[SignedEnvelope]:
        envelope, _ = self.verified(site_id, payload, "mail-request")
        ask = _decode(msgspec.msgpack.Decoder(MailRequest), envelope.body, "mail request")
        if ask.site_id != site_id or ask.center_id != self.keys.site_id:
            raise TransferRejected("the mail request names another site or center", code="misaddressed")
        now = iso(utcnow())
        with self.db.write() as conn:
            notes.mark_delivered(conn, site_id, ask.after, now)
            notes.record_poll(conn, site_id, ask.after, now)
            return notes.sealed_after(conn, site_id, ask.after, MAIL_PAGE)

    def drop_stale(self, days: float) -> int:
        """Forget transfers announced more than `days` ago and never committed (the clinic may announce again)."""
        cutoff = iso(utcnow() - dt.timedelta(days=days))
        stale = transfers.announced_before(self.db.connection(), cutoff)
        for announced in stale:
            self._drop_incoming(announced.site_id, announced.bundle_id)
            log.info(
                "dropped the unfinished transfer of %s from %s (announced before %s)",
                announced.bundle_id,
                announced.site_id,
                cutoff,
            )
        self.bundles.sweep_unfinished(older_than_s=days * 86400)
        with self.db.write() as conn:
            transfers.forget_refusals_before(conn, cutoff)
        return len(stale)

    # checks -------------------------------------------------------------------------
    def verified(self, site_id: str, payload: bytes, kind: str) -> tuple[SignedEnvelope, SiteIdentity]:
        envelope = _decode(_envelope, payload, kind)
        if envelope.protocol != PROTOCOL:
            raise TransferRejected(
                f"protocol {envelope.protocol} is not spoken here (this center speaks {PROTOCOL})", code="protocol"
            )
        if envelope.kind != kind or envelope.signer != site_id:
            raise TransferRejected(
                f"expected a {kind} signed by {site_id}, got a {envelope.kind} signed by {envelope.signer}",
                code="misaddressed",
            )
        identity = peers.trusted(self.db.connection(), site_id, SiteRole.clinic)
        try:
            verify_envelope(envelope, identity)
        except Exception as exc:
            raise TransferRejected(
                f"the {kind} is not signed by {site_id}'s enrolled key", code="bad-signature"
            ) from exc
        return envelope, identity

    def _check_manifest(self, site_id: str, m: TransferManifest) -> None:
        if m.protocol != PROTOCOL or m.site_id != site_id or m.center_id != self.keys.site_id:
            raise TransferRejected(
                f"manifest of {m.bundle_id} is addressed to {m.center_id} from {m.site_id}", code="misaddressed"
            )
        total = sum(c.size for c in m.chunks)
        if not m.chunks or total > self.config.max_bundle_mib * 1024 * 1024:
            raise TransferRejected(
                f"bundle {m.bundle_id} of {total} bytes is outside 1 byte..{self.config.max_bundle_mib}"
                " MiB ([central] max_bundle_mib)",
                code="too-large",
            )
        if max(c.size for c in m.chunks) > self.config.max_chunk_kib * 1024 + OVERHEAD:
            raise TransferRejected(
                f"bundle {m.bundle_id} has chunks over {self.config.max_chunk_kib} KiB", code="too-large"
            )

    def _check_version(self, conn, site_id: str, m: TransferManifest) -> None:
        latest = cases.latest_of_encounter(conn, site_id, m.encounter_id)
        if latest is not None and latest.version >= m.version:
            raise TransferRejected(
                f"version {m.version} of encounter {m.encounter_id} is not newer than version "
                f"{latest.version} already stored (bundle {latest.bundle_id}): a replayed or "
                "out-of-date bundle",
                code="replayed",
            )

    def _incoming(self, site_id: str, bundle_id: str) -> TransferManifest:
        cached = self._manifests.get((site_id, bundle_id))
        if cached is not None:
            return cached
        manifest = _manifest.decode(_envelope.decode(self._announcement(site_id, bundle_id).envelope).body)
        self._manifests[(site_id, bundle_id)] = manifest
        return manifest

    def _announcement(self, site_id: str, bundle_id: str) -> Announcement:
        conn = self.db.connection()
        announced = transfers.find_announcement(conn, site_id, bundle_id)
        if announced is None:
            self._check_not_refused(conn, site_id, bundle_id)
            raise TransferRejected(f"bundle {bundle_id} from {site_id} was never announced", code="unannounced")
        return announced

    def _check_not_refused(self, conn, site_id: str, bundle_id: str) -> None:
        refusal = transfers.find_refusal(conn, site_id, bundle_id)
        if refusal is not None:
            raise TransferRejected(
                f"bundle {bundle_id} was refused at {refusal.refused_at}: {refusal.reason}", code=refusal.code
            )

    def _refuse(self, site_id: str, bundle_id: str, refused: TransferRejected) -> None:
        refusal = RefusedBundle(site_id, bundle_id, refused.code, refused.detail, iso(utcnow()))
        with self.db.write() as conn:
            transfers.refuse(conn, refusal)
        shutil.rmtree(self.staging / site_id / bundle_id, ignore_errors=True)
        self._manifests.pop((site_id, bundle_id), None)

    def _held(self, site_id: str, manifest: TransferManifest) -> list[int]:
        folder = self.staging / site_id / manifest.bundle_id
        return [i for i, ref in enumerate(manifest.chunks) if _size_ok(folder / chunk_name(i), ref.size)]

    def _drop_incoming(self, site_id: str, bundle_id: str) -> None:
        with self.db.write() as conn:
            transfers.delete_announcement(conn, site_id, bundle_id)
        shutil.rmtree(self.staging / site_id / bundle_id, ignore_errors=True)
        self._manifests.pop((site_id, bundle_id), None)

    def _lock(self, site_id: str, bundle_id: str) -> threading.Lock:
        with self._locks_guard:
            return self._locks.setdefault((site_id, bundle_id), threading.Lock())


class _DamagedChunk(Exception):
    """A staged chunk that matched its sha256 on arrival no longer authenticates: damaged on disk, to send again."""

    def __init__(self, index: int):
        super().__init__(f"chunk {index} damaged")
        self.index = index


def _decode(decoder, payload: bytes, what: str):
    try:
        return decoder.decode(payload)
    except (msgspec.DecodeError, msgspec.ValidationError) as exc:
        raise TransferRejected(f"the {what} is not a valid message ({exc})", code="garbage") from exc


def _size_ok(path: Path, size: int) -> bool:
    try:
        return path.stat().st_size == size
    except FileNotFoundError:
        return False


def _staged(path: Path) -> bytes:
    """A staged chunk's bytes; empty when it is not there (no chunk is empty: each carries its nonce and tag)."""
    try:
        return path.read_bytes()
    except FileNotFoundError:
        return b""
