"""Resumable uploads (tus 1.0) of photos and videos, and what happens when one completes.

Bytes stream to a .part file whose size is the upload's offset, so an upload survives the
gateway being killed and resumes where the bytes stop. One claim per upload covers a PATCH
from its first byte to the end of completion; termination, expiry and recovery take the
same claim, so none of them can pull a file from under another. Completion records the
asset and marks the upload complete in one transaction. An upload whose bytes all arrived
but that was never recorded (the gateway died during completion) is completed on the next
HEAD or by the periodic housekeeping, so a phone that saw "all bytes received" is never wrong.
"""

from __future__ import annotations

import datetime as dt
import shutil
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from base.accounts.permissions import Principal, require_capture
from base.storage import accounts as account_rows
from base.storage.blobs import MediaStore
from gateway.capture.assets import AssetService
from gateway.records.validation import require_live_encounter
from gateway.storage import uploads as upload_rows
from gateway.storage.database import Database
from gateway.wounds.choice import wound_of_patient
from processing.capture.phone_time import exif_form
from schemas.base import iso, utcnow
from schemas.capture import Asset, StoredUpload, UploadPhase
from schemas.config import Config
from schemas.errors import (
    BurnedgeError,
    Conflict,
    Forbidden,
    Gone,
    InsufficientStorage,
    InvalidInput,
    PayloadTooLarge,
    StorageError,
    TooManyAttempts,
)
from schemas.ids import uuid7

FILENAME_KEYS = ("filename", "name", "fileName")
"""Metadata keys mobile tus clients use for the file name (tus-js, TUSKit, ...)."""


@dataclass(frozen=True)
class UploadState:
    id: str
    encounter_id: str
    length: int
    offset: int
    metadata: dict[str, str]
    expires_at: dt.datetime
    phase: UploadPhase
    asset_id: str | None


def check_filename(name: str) -> str:
    """The phone's file name is kept for people, never used as a path: refuse anything path-like."""
    if not name:
        return "upload"
    if "/" in name or "\\" in name or "\x00" in name or name in (".", "..") or name.startswith(".."):
        raise InvalidInput(f"file name {name!r} looks like a path: send the bare file name (e.g. IMG_0042.HEIC)")
    if len(name) > 255:
        raise InvalidInput("file name longer than 255 characters")
    return name


class UploadService:
    def __init__(self, db: Database, config: Config, store: MediaStore, assets: AssetService):
        self.db, self.config, self.store, self.assets = db, config, store, assets
        self._claimed: set[str] = set()
        self._lock = threading.Lock()

    @contextmanager
    def claim(self, upload_id: str) -> Iterator[None]:
        """Exclusive use of one upload (a PATCH and its completion, a termination, ...)."""
        with self._lock:
            if upload_id in self._claimed:
                raise Conflict("this upload is busy (receiving bytes or being checked): ask for its offset and retry")
            self._claimed.add(upload_id)
        try:
            yield
        finally:
            with self._lock:
                self._claimed.discard(upload_id)

    # creation and status --------------------------------------------------------------
    def create(self, principal: Principal, length: int, metadata: dict[str, str]) -> UploadState:
        require_capture(principal)
        limits = self.config.uploads
        if length <= 0:
            raise InvalidInput("the file is empty (Upload-Length 0): take the picture again")
        if length > limits.max_upload_bytes:
            raise PayloadTooLarge(f"{length:,} bytes is over the {limits.max_upload_bytes:,}-byte limit")
        encounter_id = metadata.get("encounter_id")
        if not encounter_id:
            raise InvalidInput("say which encounter the file belongs to: Upload-Metadata encounter_id")
        filename = check_filename(next((metadata[k] for k in FILENAME_KEYS if metadata.get(k)), ""))
        if metadata.get("captured_at"):
            exif_form(metadata["captured_at"])  # refused now, not after the whole file has come
        upload_id, now = uuid7(), utcnow()
        with self.db.write() as conn:
            encounter = require_live_encounter(conn, encounter_id)
            if metadata.get("wound_id"):
                wound_of_patient(conn, encounter.value().patient_id, metadata["wound_id"], "Upload-Metadata wound_id")
            open_uploads = upload_rows.open_uploads(conn)
            if sum(u.created_by == principal.user_id for u in open_uploads) >= limits.max_open_per_user:
                raise TooManyAttempts(
                    f"you have {limits.max_open_per_user} unfinished uploads: finish or cancel some first",
                    retry_after_s=60,
                )
            self._check_disk(open_uploads, length)
            upload = StoredUpload(
                id=upload_id,
                encounter_id=encounter_id,
                length=length,
                metadata=metadata,
                filename=filename,
                state=UploadPhase.open,
                created_by=principal.user_id,
                device_id=principal.device_id,
                created_at=iso(now),
                expires_at=iso(now + dt.timedelta(seconds=limits.expiry_s)),
                asset_id=None,
                error=None,
            )
            upload_rows.insert_upload(conn, upload)
            self.store.create_part(upload_id)
        return self._state(self._row(upload_id))

    def _check_disk(self, open_uploads: list[StoredUpload], length: int) -> None:
        """What open uploads will still write counts as used: abandoned ones hold it until they expire."""
        outstanding = sum(u.length - self._held(u.id) for u in open_uploads)
        free = shutil.disk_usage(self.store.root).free
        if free - outstanding - length < self.config.uploads.min_free_bytes:
            raise InsufficientStorage(
                f"the gateway has {free // 1024**2:,} MB free, not enough for this {length // 1024**2:,} MB file:"
                " ask the clinic's IT to free space (older analyses can be archived)"
            )

    def status(self, principal: Principal, upload_id: str) -> UploadState:
        """For HEAD and GET; a full upload that was never recorded is completed first."""
        require_capture(principal)
        row = self._owned_row(principal, upload_id)
        if row.state is UploadPhase.complete:
            return self._state(row)
        row = self._live_row(upload_id)
        if self._held(upload_id) == row.length:
            try:
                self.recover_one(upload_id)
            except Conflict:
                pass  # its own PATCH is completing it right now
            row = self._row(upload_id)
        return self._state(row)

    # appending and completing (the caller holds the claim) ---------------------------------
    def open_for_append(self, principal: Principal, upload_id: str, offset: int) -> tuple[Path, UploadState]:
        require_capture(principal)
        self._owned_row(principal, upload_id)
        state = self._state(self._live_row(upload_id))
        if offset != state.offset:
            raise Conflict(
                f"Upload-Offset {offset} does not match the {state.offset} bytes the gateway holds: resume from there"
            )
        return self.store.part(upload_id), state

    def complete(self, principal: Principal, upload_id: str) -> Asset:
        """All bytes are in: check the file and record it, or delete it and say why."""
        row = self._row(upload_id)
        part = self.store.part(upload_id)
        try:
            return self.assets.store_upload(
                principal,
                row.encounter_id,
                part,
                row.filename,
                upload_id=upload_id,
                expected=row.metadata.get("checksum"),
                wound_id=row.metadata.get("wound_id") or None,
                stated_time=row.metadata.get("captured_at") or None,
            )
        except StorageError:
            raise  # the database was busy: the file stays, and housekeeping completes it later
        except BurnedgeError as exc:
            part.unlink(missing_ok=True)
            self._finish(upload_id, UploadPhase.failed, error=exc.detail)
            raise

    # ending uploads --------------------------------------------------------------------------
    def terminate(self, principal: Principal, upload_id: str) -> None:
        require_capture(principal)
        self._owned_row(principal, upload_id)
        with self.claim(upload_id):
            self._live_row(upload_id)
            self.store.part(upload_id).unlink(missing_ok=True)
            self._finish(upload_id, UploadPhase.terminated)

    def housekeeping(self) -> tuple[int, int]:
        """Complete full uploads left unrecorded by a crash; drop expired unfinished ones. (completed, dropped)"""
        completed = dropped = 0
        now = iso(utcnow())
        for upload in upload_rows.open_uploads(self.db.connection()):
            try:
                if self._held(upload.id) == upload.length:
                    completed += self.recover_one(upload.id) is not None
                elif upload.expires_at < now:
                    with self.claim(upload.id):
                        self.store.part(upload.id).unlink(missing_ok=True)
                        dropped += self._finish(upload.id, UploadPhase.expired)
            except Conflict:
                continue  # busy right now: its own request finishes it
        return completed, dropped

    def recover_one(self, upload_id: str) -> Asset | None:
        """Complete an upload whose bytes all arrived, as the person who sent them."""
        row = self._row(upload_id)
        stored_user = account_rows.find_user(self.db.connection(), row.created_by)
        if stored_user is None:
            return None
        user = stored_user.user
        sender = Principal(row.created_by, user.username, user.role, row.device_id, "")
        with self.claim(upload_id):
            if self._row(upload_id).state is not UploadPhase.open:
                return None
            try:
                return self.complete(sender, upload_id)
            except StorageError:
                return None
            except BurnedgeError:
                return None  # recorded as failed, with its reason, by complete()

    # rows ------------------------------------------------------------------------------------
    def _held(self, upload_id: str) -> int:
        part = self.store.part(upload_id)
        return part.stat().st_size if part.exists() else 0

    def _row(self, upload_id: str) -> StoredUpload:
        return upload_rows.get_upload(self.db.connection(), upload_id)

    def _owned_row(self, principal: Principal, upload_id: str) -> StoredUpload:
        """Uploads belong to who started them, or to the phone they were started from (shared clinic phones)."""
        row = self._row(upload_id)
        same_device = principal.device_id is not None and principal.device_id == row.device_id
        if row.created_by != principal.user_id and not same_device:
            raise Forbidden("this upload was started by someone else on another phone")
        return row

    def _live_row(self, upload_id: str) -> StoredUpload:
        row = self._row(upload_id)
        if row.state is not UploadPhase.open:
            reason = f": {row.error}" if row.error else ""
            raise Gone(f"this upload is {row.state.value}{reason}; start a new one")
        if dt.datetime.fromisoformat(row.expires_at) < utcnow():
            raise Gone("this upload expired before it was finished: start a new one")
        return row

    def _state(self, row: StoredUpload) -> UploadState:
        offset = row.length if row.state is UploadPhase.complete else self._held(row.id)
        return UploadState(
            id=row.id,
            encounter_id=row.encounter_id,
            length=row.length,
            offset=offset,
            metadata=row.metadata,
            expires_at=dt.datetime.fromisoformat(row.expires_at),
            phase=row.state,
            asset_id=row.asset_id,
        )

    def _finish(self, upload_id: str, phase: UploadPhase, *, error: str | None = None) -> bool:
        """Move an open upload to its end state; False if it had already ended another way."""
        with self.db.write() as conn:
            return upload_rows.end_upload(conn, upload_id, phase, error)
