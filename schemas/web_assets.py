"""The vendored browser libraries: one entry of base/web/static/vendor/MANIFEST.json per file we ship."""

from __future__ import annotations

from typing import Annotated

import msgspec

from schemas.base import Frozen

Sha256 = Annotated[str, msgspec.Meta(pattern=r"\A[0-9a-f]{64}\Z", description="Lower-case hex SHA-256.")]


class NpmSource(Frozen):
    """Where a vendored file came from: the npm tarball `npm pack` fetched, and the registry's checksum of it."""

    tarball: str
    """The tarball's file name, e.g. htmx.org-2.0.11.tgz."""
    integrity: str
    """`npm view NAME@VERSION dist.integrity` (Subresource Integrity form, sha512-...)."""


class VendoredAsset(Frozen):
    """One file under base/web/static/vendor/, exactly as its npm package ships it."""

    package: str
    """The npm package name, e.g. @google/model-viewer."""
    version: str
    licence: str
    """SPDX licence expression covering the file, bundled libraries included."""
    source: NpmSource
    path: str
    """Relative to base/web/static/vendor/, forward slashes."""
    sha256: Sha256
