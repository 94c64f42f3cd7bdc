"""The error hierarchy shared by every package.

Library code raises these; the gateway maps them to problem+json and the CLI to exit
codes, each in one place (base/web/errors.py, burnedge/cli.py). They live beside the
schemas because every other package already depends on this one.
"""

from __future__ import annotations

import re
from typing import Any

from schemas.problem import FieldProblem

_OBJECT_REPR = re.compile(r"\s*<[^<>]*\bat 0x[0-9a-fA-F]+>")
_ERRNO = re.compile(r"\[Errno -?\d+\]\s*")


def plain(exc: BaseException) -> str:
    """A library's message about a file, fit for a person: no object reprs ("<_io.BytesIO object at 0x7f...>"),
    no "[Errno 1094995529]" codes. Callers say which file and what was being done."""
    text = _ERRNO.sub("", _OBJECT_REPR.sub("", str(exc))).strip(" :;,")
    return text or type(exc).__name__


class BurnedgeError(Exception):
    """Base class. `status` is the HTTP status, `slug` names the problem type."""

    status = 500
    slug = "internal-error"
    title = "Internal error"

    def __init__(self, detail: str, *, errors: list[FieldProblem] | None = None, current: Any = None):
        super().__init__(detail)
        self.detail = detail
        self.errors = errors or []
        self.current = current


class InvalidInput(BurnedgeError):
    """The input is impossible or inconsistent (e.g. weight 0 kg, injury time in the future)."""

    status = 422
    slug = "invalid-input"
    title = "Invalid input"


class MissingData(InvalidInput):
    """A calculation needs data the record does not hold yet."""

    slug = "missing-data"
    title = "Missing data"


class NotFound(BurnedgeError):
    status = 404
    slug = "not-found"
    title = "Not found"


class Conflict(BurnedgeError):
    """The write clashes with what is stored (duplicate id with other content, deleted record)."""

    status = 409
    slug = "conflict"
    title = "Conflict"


class DuplicateRow(Conflict):
    """A row with the same key is stored already (a uniqueness constraint refused the insert); raised by both
    databases' write transactions, after rolling back, so callers tell "someone else stored it" from a fault."""

    slug = "duplicate"
    title = "Already stored"


class VersionMismatch(Conflict):
    """Optimistic concurrency: the client edited a version that is no longer current."""

    status = 412
    slug = "version-mismatch"
    title = "Precondition failed: the record has changed"


class PreconditionRequired(BurnedgeError):
    status = 428
    slug = "precondition-required"
    title = "If-Match required"


class AuthenticationFailed(BurnedgeError):
    status = 401
    slug = "unauthenticated"
    title = "Authentication required"


class Forbidden(BurnedgeError):
    status = 403
    slug = "forbidden"
    title = "Not allowed for this role"


class PasswordChangeRequired(Forbidden):
    """An administrator reset this account's password: until its user changes it, the session may only change it,
    read /auth/me and log out."""

    slug = "password-change-required"
    title = "Password change required"


class WrongPassword(Forbidden):
    """The current password given to change it is wrong (403, not 401: the session itself is fine)."""

    slug = "wrong-password"
    title = "Wrong password"


class TooManyAttempts(BurnedgeError):
    status = 429
    slug = "too-many-attempts"
    title = "Too many failed attempts"

    def __init__(self, detail: str, *, retry_after_s: int):
        super().__init__(detail)
        self.retry_after_s = retry_after_s


class StorageError(BurnedgeError):
    """The database is unusable (corrupt, wrong schema, locked beyond the timeout)."""

    status = 503
    slug = "storage-unavailable"
    title = "Storage unavailable"


class Gone(BurnedgeError):
    status = 410
    slug = "gone"
    title = "No longer available"


class PayloadTooLarge(BurnedgeError):
    status = 413
    slug = "too-large"
    title = "Too large"


class UnsupportedMedia(InvalidInput):
    status = 415
    slug = "unsupported-media"
    title = "Unsupported media"


class ChecksumMismatch(BurnedgeError):
    """tus checksum extension: the body did not match its Upload-Checksum; nothing of it was kept."""

    status = 460
    slug = "checksum-mismatch"
    title = "Checksum mismatch"


class InsufficientStorage(BurnedgeError):
    status = 507
    slug = "insufficient-storage"
    title = "The gateway's disk is nearly full"


class BadRequest(BurnedgeError):
    """The request itself is malformed (a header the protocol does not allow)."""

    status = 400
    slug = "bad-request"
    title = "Bad request"


class TusVersionUnsupported(BurnedgeError):
    status = 412
    slug = "tus-version"
    title = "Unsupported tus version"


class CaptureInsufficient(InvalidInput):
    """The pictures cannot give a measurement (too few placed, one viewpoint, mixed scenes...).

    `code` is a `schemas.reconstruction.FailureCode` value; the detail tells the clinician what to retake.
    """

    slug = "capture-insufficient"
    title = "Capture insufficient for 3D analysis"

    def __init__(self, detail: str, *, code: str):
        super().__init__(detail)
        self.code = code


class MissingKeys(InvalidInput):
    """This site has no keys yet (`burnedge keys init`)."""

    status = 503
    slug = "missing-keys"
    title = "This site has no keys"


class TransferRejected(BurnedgeError):
    """A bundle, chunk or message from a peer failed a check; `code` names which (logged, and told the sender)."""

    status = 422
    slug = "transfer-rejected"
    title = "Transfer rejected"

    def __init__(self, detail: str, *, code: str):
        super().__init__(detail)
        self.code = code


class ModelExportError(BurnedgeError):
    """A trained network's ONNX export failed its check (batch norms left unfolded, or onnxruntime answering
    differently from the network): no model file is written."""

    slug = "model-export-failed"
    title = "The model's export failed its check"


class PacsNotConfigured(Conflict):
    """A send to the hospital's PACS was asked of a server without `[dicom] endpoint`."""

    slug = "pacs-not-configured"
    title = "No PACS is configured"


class PacsFailed(BurnedgeError):
    """The PACS could not be reached, refused the study (a 4xx) or stored only part of it: nothing is marked as
    sent, and sending again stores each object once (its UIDs are stable)."""

    status = 502
    slug = "pacs-failed"
    title = "The hospital's PACS did not store the study"
