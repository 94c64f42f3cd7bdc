"""The consultants' list of cases, a page at a time (`bundles`): read along an index in the list's order, so a page
costs the same at a hundred cases or a million, with a cursor that stays put while new cases arrive."""

from __future__ import annotations

import base64
import binascii
import datetime as dt
import sqlite3

import msgspec

from center.storage.cases import CASE_SQL, case_item
from schemas.central import CaseFilter, CaseItem, CaseState
from schemas.errors import InvalidInput
from schemas.transfer import URGENCY_ORDER

# The list's order, and the row value a cursor holds: the latest versions before superseded ones, awaiting advice
# before advised, then most urgent, then longest waiting. It is the order of the index bundles_queue.
_ORDER = ("b.superseded", "b.advised", "b.urgency_rank", "b.stored_at", "b.site_id", "b.bundle_id")
_Cursor = tuple[int, int, int, str, str, str]
_cursor = msgspec.msgpack.Decoder(_Cursor)


def _conditions(wanted: CaseFilter) -> tuple[list[str], list]:
    where: list[str] = []
    params: list = []
    if wanted.state is CaseState.superseded:
        where.append("b.superseded = 1")
    elif wanted.state is not None or not wanted.include_superseded:
        where.append("b.superseded = 0")
    if wanted.state is CaseState.awaiting:
        where.append("b.advised = 0")
    elif wanted.state is CaseState.advised:
        where.append("b.advised = 1")
    if wanted.urgency is not None:
        where.append("b.urgency_rank = ?")
        params.append(URGENCY_ORDER[wanted.urgency])
    if wanted.site_id is not None:
        where.append("b.site_id = ?")
        params.append(wanted.site_id)
    # stored_at is ISO 8601 in UTC with one fixed width: text order is time order, a day's bound is its date.
    if wanted.received_from is not None:
        where.append("b.stored_at >= ?")
        params.append(wanted.received_from.isoformat())
    if wanted.received_to is not None:
        where.append("b.stored_at < ?")
        params.append((wanted.received_to + dt.timedelta(days=1)).isoformat())
    return where, params


def encode_cursor(item: CaseItem) -> str:
    """Where the list goes on after this case, as the opaque text a page hands out."""
    key = (
        0 if item.superseded_by is None else 1,
        0 if item.awaiting_advice else 1,
        URGENCY_ORDER[item.urgency],
        item.stored_at,
        item.site_id,
        item.bundle_id,
    )
    return base64.urlsafe_b64encode(msgspec.msgpack.encode(key)).decode().rstrip("=")


def decode_cursor(text: str) -> _Cursor:
    try:
        return _cursor.decode(base64.urlsafe_b64decode(text + "=" * (-len(text) % 4)))
    except (binascii.Error, ValueError, msgspec.DecodeError) as exc:
        raise InvalidInput(
            "`after` is not a position this list handed out (copy `next_after` from the previous page, "
            "or leave it out to start from the first page)"
        ) from exc


def count_cases(conn: sqlite3.Connection, wanted: CaseFilter, up_to: int) -> int:
    """How many cases match the filter, on every page together, counted up to `up_to` + 1 (a count reads every
    matching index entry: at a hundred thousand cases that alone would take longer than the page)."""
    where, params = _conditions(wanted)
    sql = "SELECT 1 FROM bundles b" + (" WHERE " + " AND ".join(where) if where else "") + " LIMIT ?"
    return conn.execute(f"SELECT COUNT(*) FROM ({sql}) AS matching", [*params, up_to + 1]).fetchone()[0]


def page_of_cases(conn: sqlite3.Connection, wanted: CaseFilter) -> tuple[list[CaseItem], str | None]:
    """The filter's page of cases in the list's order, and the cursor of the page after it (None on the last)."""
    where, params = _conditions(wanted)
    if wanted.after is not None:
        where.append(f"({', '.join(_ORDER)}) > (?, ?, ?, ?, ?, ?)")
        params.extend(decode_cursor(wanted.after))
    sql = CASE_SQL + (" WHERE " + " AND ".join(where) if where else "")
    sql += f" ORDER BY {', '.join(_ORDER)} LIMIT ?"
    rows = conn.execute(sql, [*params, wanted.limit + 1]).fetchall()
    items = [case_item(r) for r in rows[: wanted.limit]]
    more = len(rows) > wanted.limit
    return items, encode_cursor(items[-1]) if more else None
