"""The pages' static files (our own js/css and the vendored libraries) served at /static, and the vendor manifest.

Anonymous browsers get them too: the sign-in page needs its scripts before anyone has logged in. Nothing here is
secret; every file is one we ship in the package.
"""

from __future__ import annotations

from pathlib import Path

import msgspec
from litestar import Router
from litestar.datastructures import CacheControlHeader
from litestar.static_files import create_static_files_router

from base.web.authentication import EXCLUDE_OPT_KEY
from schemas.web_assets import VendoredAsset

STATIC_DIR = Path(__file__).resolve().parent.parent / "static"
"""base/web/static: js/ and css/ are ours, vendor/ the libraries listed in vendor/MANIFEST.json."""
VENDOR_DIR = STATIC_DIR / "vendor"
STATIC_PATH = "/static"
CACHE_SECONDS = 86_400


def static_files() -> Router:
    """GET /static/{file_path}: files under STATIC_DIR, cached a day, no login needed, not in the API's schema."""
    return create_static_files_router(
        path=STATIC_PATH,
        directories=[STATIC_DIR],
        cache_control=CacheControlHeader(public=True, max_age=CACHE_SECONDS),
        include_in_schema=False,
        opt={EXCLUDE_OPT_KEY: True},
    )


def manifest() -> list[VendoredAsset]:
    """Every vendored file with its package, version, licence, npm source and SHA-256."""
    return msgspec.json.decode((VENDOR_DIR / "MANIFEST.json").read_bytes(), type=list[VendoredAsset])
