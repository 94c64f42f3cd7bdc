"""Files in and out of a page form: the bytes of one uploaded file (bounded), and a file answered as a download."""

from __future__ import annotations

from typing import Any

from litestar import Response
from litestar.datastructures import UploadFile


async def uploaded_bytes(data: dict[str, Any], name: str, limit: int) -> bytes:
    """The file posted as `name` in a multipart form, at most `limit` + 1 bytes (the caller refuses more);
    b"" when none was chosen."""
    upload = data.get(name)
    if not isinstance(upload, UploadFile):
        return b""
    try:
        return await upload.read(limit + 1)
    finally:
        await upload.close()


def download(content: bytes, filename: str, media_type: str) -> Response:
    """`content` as a file the browser saves under `filename`."""
    return Response(
        content, media_type=media_type, headers={"Content-Disposition": f'attachment; filename="{filename}"'}
    )
