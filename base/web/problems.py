"""The error answers each operation publishes in the OpenAPI document: every one an RFC 9457 problem.

base/web/errors.py turns every error into a `Problem` (schemas/problem.py) sent as application/problem+json; a
handler names the statuses it can answer with `responses=problems(...)`, so clients (and the schema fuzz in
tests/test_fuzz_api.py) know what to expect. Litestar's own 400 entry describes its default error body, not ours:
listing 400 here replaces it.
"""

from __future__ import annotations

from litestar.openapi import ResponseSpec

from base.web.errors import PROBLEM_JSON
from schemas.problem import Problem

MEANING = {
    400: "The request is malformed (a field, a parameter, a header or the JSON itself): nothing was stored",
    401: "No valid session (log in again), or a wrong username, password or code",
    403: "Your role may not do this, a wrong current password, or your password must be changed first (after an "
    "administrator's reset only POST /api/v1/auth/password, GET /api/v1/auth/me and logout are open)",
    404: "No such record",
    409: "Conflicts with what is stored (`current` holds the stored record where there is one), or the server is not "
    "set up for it (no PACS configured)",
    410: "The upload was finished, abandoned or has expired: start a new one",
    412: "A precondition failed: the version you edited is no longer the current one (`current` holds it), the part "
    "already exists (If-None-Match: *), or a tus request without Tus-Resumable: 1.0.0",
    413: "Too large: the body, or the declared Upload-Length",
    415: "Wrong Content-Type",
    422: "Well-formed but not acceptable (e.g. a time before the injury, a bad If-Match): nothing was stored",
    428: "If-Match with the version you edited (the ETag of your last read) is required",
    429: "Too many attempts: wait as long as Retry-After says",
    460: "The bytes received do not match Upload-Checksum: nothing of the request was kept",
    502: "The hospital's PACS did not store the study (unreachable, refused, or only part of it): the failed send is "
    "recorded, nothing is marked as sent; sending again stores each object once",
    507: "The gateway's disk has no room for this upload",
}

SESSION = (401, 403)
"""Any operation behind a session whose role is checked."""
ONE = (400, *SESSION, 404)
"""An operation on one record named in the path."""
BODY = (400, 413)
"""An operation with a JSON body: invalid, or over [gateway] max_body_bytes."""


def problems(*statuses: int) -> dict[int, ResponseSpec]:
    """Problem responses for `statuses`, for a route handler's `responses=`."""
    return {
        status: ResponseSpec(
            data_container=Problem, media_type=PROBLEM_JSON, description=MEANING[status], generate_examples=False
        )
        for status in sorted(set(statuses))
    }
