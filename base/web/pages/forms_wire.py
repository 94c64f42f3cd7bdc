"""A form's wire format: what a browser posts for a Struct, input name -> list of strings, in both directions.

Names are the field names, dotted into nested Structs ("airway.patent") and indexed into lists
("medications[0].name", "significant_comorbidities[1]"). Lists are compacted before use: rows left entirely blank
(or at their defaults) are dropped and the rest renumbered from 0, so the names in error messages, in the form
shown again and in the stored list's JSON paths ("$.medications[1].name") all agree.
"""

from __future__ import annotations

import datetime as dt
import enum
import re
from collections.abc import Iterable
from typing import Any

from base.web.pages.forms_spec import NO, YES, FieldSpec

CHECKED = "yes"
"""The value a checked checkbox sends."""
_UNCHECKED = {"", "no", "false", "off", "0"}


def read_raw(raw: Any) -> dict[str, list[str]]:
    """A Litestar FormMultiDict or a mapping of name -> str or list of str, as name -> list of str.

    Browsers send a textarea's line breaks as CRLF; they become "\\n" here so a text reads back as it was stored.
    """
    getall = getattr(raw, "getall", None)
    out: dict[str, list[str]] = {}
    for key in dict.fromkeys(raw.keys()):
        values = getall(key) if getall is not None else raw[key]
        if isinstance(values, str):
            values = [values]
        texts = [v.replace("\r\n", "\n").replace("\r", "\n") for v in values if isinstance(v, str)]
        if texts:
            out[str(key)] = texts
    return out


def first(posted: dict[str, list[str]], name: str) -> str:
    return posted.get(name, [""])[0]


def checked(values: Iterable[str]) -> bool:
    return any(v.strip().lower() not in _UNCHECKED for v in values)


def number_text(x: float) -> str:
    """70.0 -> "70", 37.5 -> "37.5": the shortest text that reads back as the same number."""
    if isinstance(x, float) and x.is_integer() and abs(x) < 1e15:
        return str(int(x))
    return str(x)


def local_text(t: dt.datetime, tz: dt.tzinfo | None) -> str:
    """An instant as `<input type=datetime-local>` shows it: wall time in `tz` (None: this machine's zone).

    Seconds and milliseconds are written only when set (the input allows no finer than milliseconds)."""
    local = (t.astimezone(tz) if tz is not None else t.astimezone()).replace(tzinfo=None)
    if local.microsecond:
        return local.isoformat(timespec="milliseconds")
    return local.isoformat(timespec="seconds" if local.second else "minutes")


def form_text(spec: FieldSpec, value: Any, tz: dt.tzinfo | None) -> str:
    """The string an input shows for a stored value."""
    if value is None:
        return ""
    if spec.kind == "tristate":
        return YES if value else NO
    if isinstance(value, enum.Enum):
        return str(value.value)
    if isinstance(value, dt.datetime):
        return local_text(value, tz)
    if isinstance(value, dt.date):
        return value.isoformat()
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return number_text(value)
    return str(value)


def encode(specs: Iterable[FieldSpec], instance: Any, tz: dt.tzinfo | None, prefix: str = "") -> dict[str, list[str]]:
    """What a browser would post for `instance` (None: a new form, every field at its default, but every select at
    its blank option: a value the person did not choose is never shown chosen)."""
    out: dict[str, list[str]] = {}
    for spec in specs:
        if instance is not None:
            value = getattr(instance, spec.name)
        else:
            value = None if spec.kind in ("group", "select") else spec.default
        name = prefix + spec.name
        if spec.kind == "group":
            out.update(encode(spec.children, value, tz, name + "."))
        elif spec.kind == "list":
            for i, item in enumerate(value or ()):
                if spec.item.kind == "group":
                    out.update(encode(spec.item.children, item, tz, f"{name}[{i}]."))
                else:
                    out[f"{name}[{i}]"] = [form_text(spec.item, item, tz)]
        elif spec.kind == "checkbox":
            if value:
                out[name] = [CHECKED]
        else:
            out[name] = [form_text(spec, value, tz)]
    return out


def is_known(specs: Iterable[FieldSpec], name: str) -> bool:
    """Whether `name` is an input the form for `specs` can have ("airway.patent", "medications[3].dose")."""
    for spec in specs:
        if spec.kind == "group" and name.startswith(spec.name + "."):
            return is_known(spec.children, name[len(spec.name) + 1 :])
        if spec.kind == "list" and (m := _row_pattern(spec.name).match(name)):
            if spec.item.kind == "group":
                return m[2].startswith(".") and is_known(spec.item.children, m[2][1:])
            return m[2] == ""
        if name == spec.name and spec.kind not in ("group", "list"):
            return True
    return False


def _row_pattern(name: str) -> re.Pattern[str]:
    return re.compile(re.escape(name) + r"\[(\d{1,6})\]((?:[.\[].*)?)\Z", re.S)


def row_indices(posted: dict[str, list[str]], name: str) -> list[int]:
    pattern = _row_pattern(name)
    return sorted({int(m[1]) for key in posted if (m := pattern.match(key))})


def compact_rows(specs: Iterable[FieldSpec], posted: dict[str, list[str]], prefix: str = "") -> dict[str, list[str]]:
    """`posted` with every list's blank rows dropped and the others renumbered 0, 1, 2..."""
    data = dict(posted)
    _compact(specs, prefix, data)
    return data


def _compact(specs: Iterable[FieldSpec], prefix: str, data: dict[str, list[str]]) -> None:
    for spec in specs:
        name = prefix + spec.name
        if spec.kind == "group":
            _compact(spec.children, name + ".", data)
        elif spec.kind == "list":
            pattern = _row_pattern(name)
            rows: dict[int, dict[str, list[str]]] = {}
            for key in list(data):
                if m := pattern.match(key):
                    rows.setdefault(int(m[1]), {})[m[2]] = data.pop(key)
            defaults = default_texts(spec.item)
            kept = [rows[i] for i in sorted(rows) if not _blank(rows[i], defaults)]
            for k, row in enumerate(kept):
                data.update({f"{name}[{k}]{suffix}": values for suffix, values in row.items()})
                if spec.item.kind == "group":
                    _compact(spec.item.children, f"{name}[{k}].", data)


def default_texts(spec: FieldSpec, suffix: str = "") -> dict[str, str | None]:
    """Name suffix within a list row -> the text its input starts with in a new row (None: an unchecked box)."""
    if spec.kind == "group":
        out: dict[str, str | None] = {}
        for child in spec.children:
            out.update(default_texts(child, f"{suffix}.{child.name}"))
        return out
    if spec.kind == "checkbox":
        return {suffix: CHECKED if spec.default else None}
    return {suffix: form_text(spec, spec.default, None) if spec.has_default else ""}


def _blank(row: dict[str, list[str]], defaults: dict[str, str | None]) -> bool:
    """Every known input of the row is empty or still at the value a new row starts with."""
    return all(
        not value.strip() or value == defaults[suffix]
        for suffix, values in row.items()
        if suffix in defaults
        for value in values
    )
