"""Small JPEG previews of the pictures for the pages: a phone on the clinic's Wi-Fi should not pull a 4 MB photo
to show a 160 px tile. Made once per picture (by content hash) and kept beside the media store."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import cv2
import numpy as np

from base.accounts.permissions import Principal
from base.folders import media_root
from gateway.capture.assets import AssetService
from schemas.config import Config
from schemas.errors import NotFound

THUMBNAIL_EDGE = 480
"""Longest edge of a preview in pixels: sharp on a 2x tablet tile, about 40 kB."""


class ThumbnailService:
    def __init__(self, config: Config, assets: AssetService):
        self.folder = media_root(config) / "thumbnails"
        self.assets = assets

    def thumbnail(self, principal: Principal, asset_id: str) -> Path:
        """The preview of a photo or frame (the asset service checks the reader's right to it)."""
        asset, source = self.assets.file(principal, asset_id)
        if asset.media_type.is_video:
            raise NotFound("a video has no preview picture: its extracted frames do")
        target = self.folder / f"{asset.sha256}.jpg"
        if not target.exists():
            self._make(source, target)
        return target

    def _make(self, source: Path, target: Path) -> None:
        image = cv2.imdecode(np.fromfile(source, dtype=np.uint8), cv2.IMREAD_COLOR)
        if image is None:
            raise NotFound("this picture's format cannot be previewed here (e.g. HEIC); download it instead")
        scale = THUMBNAIL_EDGE / max(image.shape[:2])
        if scale < 1:
            image = cv2.resize(image, None, fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
        ok, encoded = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 82])
        if not ok:
            raise NotFound("the preview could not be made; download the picture instead")
        self.folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=self.folder, suffix=".part")
        with os.fdopen(fd, "wb") as f:
            f.write(encoded.tobytes())
        os.replace(tmp, target)
