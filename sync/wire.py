"""Request and answer over Zenoh queries: an answer is the reply's payload; a refusal is a reply error carrying
the reason as JSON; silence until the timeout means the link (or the center) is down."""

from __future__ import annotations

import msgspec

from schemas.errors import BurnedgeError, TransferRejected


class LinkDown(BurnedgeError):
    """The peer could not be reached or did not answer in time; the work waits for the next round."""

    status = 503
    slug = "link-down"
    title = "No link to the peer"


class Refusal(msgspec.Struct, frozen=True):
    code: str
    reason: str


def refusal(exc: TransferRejected) -> bytes:
    return msgspec.json.encode(Refusal(code=exc.code, reason=exc.detail))


def error_text(reply) -> str:
    raw = reply.err.payload.to_bytes()
    try:
        return msgspec.json.decode(raw, type=Refusal).reason
    except msgspec.DecodeError:
        return raw.decode("utf-8", errors="replace")[:500]


def request(session, key: str, payload: bytes, timeout_s: float) -> bytes:
    """The peer's answer to one request; TransferRejected with its reason when it refuses."""
    for reply in session.get(key, payload=payload, timeout=timeout_s):
        if reply.ok is not None:
            return reply.ok.payload.to_bytes()
        raw = reply.err.payload.to_bytes()
        try:
            refused = msgspec.json.decode(raw, type=Refusal)
        except msgspec.DecodeError:
            refused = Refusal(code="refused", reason=raw.decode("utf-8", errors="replace")[:500])
        raise TransferRejected(refused.reason, code=refused.code)
    raise LinkDown(f"no answer to {key.split('/')[2]} within {timeout_s:g} s (no route to the center, or it is down)")
