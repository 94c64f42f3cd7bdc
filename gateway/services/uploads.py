"""Resumable uploads (tus 1.0) of photos and videos, and what happens when one completes.

Bytes stream to a .part file; its size is the upload's offset, so an upload survives the
gateway being killed and resumes where the bytes stop. On completion the file is hashed,
its type is read from its bytes, it is checked whole, moved into the content-addressed
store and recorded as an asset with its capture metadata and, for photos, the quality
verdict. A file that fails any check is deleted and the upload marked failed: nothing is
left half-stored.
"""

from __future__ import annotations

import datetime as dt
import json
import shutil
import threading
from dataclasses import dataclass
from pathlib import Path

from gateway.services.assets import AssetService
from gateway.services.permissions import Principal, require_capture
from gateway.services.validation import require_live_encounter
from gateway.storage.blobs import MediaStore
from gateway.storage.database import Database
from schemas.base import iso, utcnow
from schemas.capture import Asset
from schemas.config import Config
from schemas.errors import BurnedgeError, Conflict, Gone, InsufficientStorage, InvalidInput, NotFound, PayloadTooLarge
from schemas.ids import uuid7


@dataclass(frozen=True)
class UploadState:
    id: str
    encounter_id: str
    length: int
    offset: int
    metadata: dict[str, str]
    expires_at: dt.datetime
    state: str
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
        self._busy: set[str] = set()
        self._busy_lock = threading.Lock()

    def create(self, principal: Principal, length: int, metadata: dict[str, str]) -> UploadState:
        require_capture(principal)
        if length <= 0:
            raise InvalidInput("the file is empty (Upload-Length 0): take the picture again")
        if length > self.config.uploads.max_upload_bytes:
            raise PayloadTooLarge(f"{length:,} bytes is over the {self.config.uploads.max_upload_bytes:,}-byte limit")
        free = shutil.disk_usage(self.store.root).free
        if free - self._outstanding_bytes() - length < self.config.uploads.min_free_bytes:
            raise InsufficientStorage(
                f"the gateway has {free // 1024**2:,} MB free, not enough for this {length // 1024**2:,} MB file:"
                " ask the clinic's IT to free space (older analyses can be archived)"
            )
        encounter_id = metadata.get("encounter_id")
        if not encounter_id:
            raise InvalidInput("say which encounter the file belongs to: Upload-Metadata encounter_id")
        filename = check_filename(metadata.get("filename") or metadata.get("name") or "")
        upload_id, now = uuid7(), utcnow()
        expires = now + dt.timedelta(seconds=self.config.uploads.expiry_s)
        with self.db.write() as conn:
            require_live_encounter(conn, encounter_id)
            conn.execute(
                "INSERT INTO uploads (id, encounter_id, length, metadata, filename, state, created_by, device_id,"
                " created_at, expires_at) VALUES (?,?,?,?,?,?,?,?,?,?)",
                (upload_id, encounter_id, length, json.dumps(metadata), filename, "open", principal.user_id,
                 principal.device_id, iso(now), iso(expires)),
            )  # fmt: skip
            self.store.create_part(upload_id)
        return self._state(self._row(upload_id))

    def status(self, principal: Principal, upload_id: str) -> UploadState:
        require_capture(principal)
        return self._state(self._live_row(upload_id, allow_complete=True))

    def begin_append(self, principal: Principal, upload_id: str, offset: int) -> tuple[Path, UploadState]:
        """Claim the upload for one PATCH; the caller must call end_append."""
        require_capture(principal)
        row = self._live_row(upload_id, allow_complete=False)
        with self._busy_lock:
            if upload_id in self._busy:
                raise Conflict("another request is sending this upload right now: wait for it, then ask for the offset")
            self._busy.add(upload_id)
        state = self._state(row)
        if offset != state.offset:
            self.end_append(upload_id)
            raise Conflict(
                f"Upload-Offset {offset} does not match the {state.offset} bytes the gateway holds: resume from there"
            )
        return self.store.part(upload_id), state

    def end_append(self, upload_id: str) -> None:
        with self._busy_lock:
            self._busy.discard(upload_id)

    def complete(self, principal: Principal, upload_id: str) -> Asset:
        """All bytes are in: check the file and store it as an asset, or delete it and say why."""
        row = self._row(upload_id)
        part = self.store.part(upload_id)
        try:
            asset = self.assets.store_upload(principal, row["encounter_id"], part, row["filename"])
        except BurnedgeError as exc:
            part.unlink(missing_ok=True)
            self._set_state(upload_id, "failed", error=exc.detail)
            raise
        self._set_state(upload_id, "complete", asset_id=asset.id)
        return asset

    def terminate(self, principal: Principal, upload_id: str) -> None:
        require_capture(principal)
        row = self._live_row(upload_id, allow_complete=False)
        with self._busy_lock:
            if upload_id in self._busy:
                raise Conflict("this upload is receiving bytes right now: terminate it after that request ends")
        self.store.part(row["id"]).unlink(missing_ok=True)
        self._set_state(upload_id, "terminated")

    def expire(self) -> int:
        """Drop unfinished uploads past their expiry (run periodically)."""
        now = iso(utcnow())
        rows = (
            self.db.connection()
            .execute("SELECT id FROM uploads WHERE state = 'open' AND expires_at < ?", (now,))
            .fetchall()
        )
        dropped = 0
        for row in rows:
            with self._busy_lock:
                if row["id"] in self._busy:
                    continue  # still receiving: its PATCH finishes first
            self.store.part(row["id"]).unlink(missing_ok=True)
            self._set_state(row["id"], "expired")
            dropped += 1
        return dropped

    # ------------------------------------------------------------------------------------
    def _outstanding_bytes(self) -> int:
        """What open uploads will still write: their declared lengths minus what they hold."""
        rows = self.db.connection().execute("SELECT id, length FROM uploads WHERE state = 'open'").fetchall()
        held = {r["id"]: self.store.part(r["id"]) for r in rows}
        return sum(r["length"] - (held[r["id"]].stat().st_size if held[r["id"]].exists() else 0) for r in rows)

    def _row(self, upload_id: str):
        row = self.db.connection().execute("SELECT * FROM uploads WHERE id = ?", (upload_id,)).fetchone()
        if row is None:
            raise NotFound(f"no upload {upload_id}")
        return row

    def _live_row(self, upload_id: str, *, allow_complete: bool):
        row = self._row(upload_id)
        if row["state"] == "complete" and allow_complete:
            return row
        if row["state"] != "open":
            raise Gone(
                f"this upload is {row['state']}" + (f": {row['error']}" if row["error"] else "") + "; start a new one"
            )
        if dt.datetime.fromisoformat(row["expires_at"]) < utcnow():
            raise Gone("this upload expired before it was finished: start a new one")
        return row

    def _state(self, row) -> UploadState:
        part = self.store.part(row["id"])
        offset = row["length"] if row["state"] == "complete" else (part.stat().st_size if part.exists() else 0)
        return UploadState(id=row["id"], encounter_id=row["encounter_id"], length=row["length"], offset=offset,
                           metadata=json.loads(row["metadata"]), expires_at=dt.datetime.fromisoformat(row["expires_at"]),
                           state=row["state"], asset_id=row["asset_id"])  # fmt: skip

    def _set_state(self, upload_id: str, state: str, *, asset_id: str | None = None, error: str | None = None) -> None:
        with self.db.write() as conn:
            conn.execute("UPDATE uploads SET state = ?, asset_id = COALESCE(?, asset_id), error = ? WHERE id = ?",
                         (state, asset_id, error, upload_id))  # fmt: skip
