"""Browser forms from msgspec Structs: the fields to render, and the Struct back from what the browser posted.

The schemas are the single source of every form's fields, limits and messages (base/web/pages/forms_spec.py).
A form with invalid input raises FormInvalid naming every bad input; the page shows the form again with
`form_fields(T, raw=posted, errors=field_errors(exc.errors))`, and nothing is stored.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from typing import Annotated, Any

import msgspec
from litestar.enums import RequestEncodingType
from litestar.params import Body

from base.web.pages.forms_fields import FormField, errors_in, form_fields
from base.web.pages.forms_spec import NO, YES, FieldSpec, struct_fields
from base.web.pages.forms_wire import checked, compact_rows, first, is_known, number_text, read_raw, row_indices
from base.web.pages.session import CSRF_FIELD
from schemas.errors import InvalidInput
from schemas.problem import FieldProblem

__all__ = ["FormBody", "FormField", "FormInvalid", "errors_in", "field_errors", "form_fields", "parse_form"]

_INT = re.compile(r"[+-]?\d{1,18}\Z")
_FLOAT = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d{1,3})?\Z")
_DATE = re.compile(r"\d{4}-\d{2}-\d{2}\Z")
_DATETIME = re.compile(r"\d{4}-\d{2}-\d{2}[T ]\d{2}:\d{2}")
FormBody = Annotated[dict[str, Any], Body(media_type=RequestEncodingType.URL_ENCODED)]
"""A posted page form as a handler receives it: input name -> text (a list where a name repeats)."""
PAGE_FIELDS = frozenset({CSRF_FIELD, "version"})
"""Hidden inputs the pages add to every form (the CSRF token, the record's version): never a field's value."""
_AT_PATH = re.compile(r"^(?P<msg>.*?)(?: - at `(?P<path>[^`]*)`)?$", re.S)


class FormInvalid(InvalidInput):
    """A posted form that cannot become its Struct; `.errors` name the form inputs ("breathing.spo2_percent")."""

    def __init__(self, errors: list[FieldProblem]):
        listed = "; ".join(f"{p.field or 'form'}: {p.message}" for p in errors)
        super().__init__(f"nothing was stored: {listed}", errors=errors)


class _Bad(ValueError):
    """One input's value cannot be read; the message is for the person who typed it."""


def parse_form(struct_type: type, raw: Any, *, fixed: dict, tz: dt.tzinfo | None = None) -> msgspec.Struct:
    """The Struct a posted form describes; `fixed` gives the fields the page fills (ids), never read from `raw`.

    Empty inputs are None where the field is optional and leave the default where it has one; an unchecked box is
    False; list rows left blank are dropped. A datetime without an offset (what datetime-local sends) is wall time
    in `tz` (None: this machine's zone); every datetime comes back in UTC. Raises FormInvalid naming every input
    that is wrong; an input the form cannot have is "unknown field" (the page's own hidden inputs, PAGE_FIELDS, and
    the `fixed` names are ignored).
    """
    specs = [s for s in struct_fields(struct_type) if s.name not in fixed]
    received = read_raw(raw)
    problems = [
        FieldProblem(field=name, message="unknown field")
        for name in received
        if name not in fixed and name not in PAGE_FIELDS and not is_known(specs, name)
    ]
    received = {k: v for k, v in received.items() if k not in fixed and is_known(specs, k)}
    posted = compact_rows(specs, received)
    data = _parse_fields(specs, "", posted, problems, tz)
    if problems:
        raise FormInvalid(problems)
    data.update(fixed)
    try:
        return msgspec.convert(data, struct_type)
    except msgspec.ValidationError as exc:
        m = _AT_PATH.match(str(exc))
        raise FormInvalid([_problem(m["path"] or "$", m["msg"])]) from exc


def _parse_fields(specs, prefix: str, posted: dict[str, list[str]], problems: list[FieldProblem], tz) -> dict:
    data: dict[str, Any] = {}
    for spec in specs:
        name = prefix + spec.name
        if spec.kind == "group":
            data[spec.name] = _parse_fields(spec.children, name + ".", posted, problems, tz)
        elif spec.kind == "list":
            rows = []
            for i in row_indices(posted, name):
                if spec.item.kind == "group":
                    rows.append(_parse_fields(spec.item.children, f"{name}[{i}].", posted, problems, tz))
                else:
                    rows.append(_parse_one(spec.item, f"{name}[{i}]", posted, problems, tz))
            _check_rows(spec, name, len(rows), problems)
            data[spec.name] = rows
        elif spec.kind == "checkbox":
            data[spec.name] = checked(posted.get(name, ()))
        else:
            text = first(posted, name)
            if not text.strip() and not spec.optional and spec.has_default:
                continue  # the default applies
            data[spec.name] = _parse_one(spec, name, posted, problems, tz)
    return data


def _check_rows(spec: FieldSpec, name: str, count: int, problems: list[FieldProblem]) -> None:
    if spec.max_length is not None and count > spec.max_length:
        problems.append(FieldProblem(field=name, message=f"at most {spec.max_length} rows (this has {count})"))
    elif spec.min_length is not None and count < spec.min_length:
        problems.append(FieldProblem(field=name, message=f"at least {spec.min_length} rows"))


def _parse_one(spec: FieldSpec, name: str, posted, problems: list[FieldProblem], tz) -> Any:
    text = first(posted, name)
    try:
        if not text.strip():
            if spec.optional or spec.kind == "tristate":
                return None
            raise _Bad("is required")
        return _convert(spec, text, tz)
    except _Bad as exc:
        problems.append(FieldProblem(field=name, message=str(exc)))
        return None


def _convert(spec: FieldSpec, text: str, tz: dt.tzinfo | None) -> Any:
    if spec.kind == "number":
        return _number(spec, text.strip())
    if spec.kind in ("text", "textarea"):
        return _text(spec, text)
    if spec.kind == "select":
        if text not in {value for value, _ in spec.choices if value}:
            raise _Bad("choose one of the options")
        return text
    if spec.kind == "tristate":
        if text not in (YES, NO):
            raise _Bad("choose yes, no or not recorded")
        return text == YES
    if spec.kind == "date":
        return _date(text.strip())
    if spec.kind == "datetime":
        return _datetime(text.strip(), tz)
    raise TypeError(f"no form conversion for {spec.kind}")


def _number(spec: FieldSpec, text: str) -> int | float:
    if spec.number == "int":
        if not _INT.match(text):
            raise _Bad("enter a whole number" if _FLOAT.match(text) else "enter a number")
        value: int | float = int(text)
    else:
        if not _FLOAT.match(text) or not math.isfinite(value := float(text)):
            raise _Bad("enter a number")
    if spec.ge is not None and value < spec.ge:
        raise _Bad(f"must be at least {number_text(spec.ge)}")
    if spec.gt is not None and value <= spec.gt:
        raise _Bad(f"must be more than {number_text(spec.gt)}")
    if spec.le is not None and value > spec.le:
        raise _Bad(f"must be at most {number_text(spec.le)}")
    if spec.lt is not None and value >= spec.lt:
        raise _Bad(f"must be less than {number_text(spec.lt)}")
    return value


def _text(spec: FieldSpec, text: str) -> str:
    if spec.max_length is not None and len(text) > spec.max_length:
        raise _Bad(f"at most {spec.max_length} characters (this has {len(text)})")
    if spec.min_length is not None and len(text) < spec.min_length:
        raise _Bad(f"at least {spec.min_length} characters")
    if spec.pattern is not None and not re.search(spec.pattern, text):
        raise _Bad("is not in the expected form")
    return text


def _date(text: str) -> dt.date:
    try:
        if _DATE.match(text):
            return dt.date.fromisoformat(text)
    except ValueError:
        pass
    raise _Bad("must be a date like 2026-12-03")


def _datetime(text: str, tz: dt.tzinfo | None) -> dt.datetime:
    try:
        t = dt.datetime.fromisoformat(text) if _DATETIME.match(text) else None
    except ValueError:
        t = None
    if t is None:
        raise _Bad("must be a date and time like 2026-12-03T14:30")
    if t.tzinfo is None:
        # A naive datetime's astimezone() reads it as this machine's local time, daylight saving included.
        t = t.replace(tzinfo=tz) if tz is not None else t.astimezone()
    return t.astimezone(dt.UTC)  # stored as the instant in UTC, whatever zone it was typed in


_PLAIN = [
    (re.compile(r"Object missing required field `(?P<f>[^`]+)`"), "is required"),
    (re.compile(r"Expected `(?:int|float)[^`]*` >= (?P<n>\S+)"), "must be at least {n}"),
    (re.compile(r"Expected `(?:int|float)[^`]*` > (?P<n>\S+)"), "must be more than {n}"),
    (re.compile(r"Expected `(?:int|float)[^`]*` <= (?P<n>\S+)"), "must be at most {n}"),
    (re.compile(r"Expected `(?:int|float)[^`]*` < (?P<n>\S+)"), "must be less than {n}"),
    (re.compile(r"Expected `str` of length <= (?P<n>\d+)"), "at most {n} characters"),
    (re.compile(r"Expected `str` matching regex"), "is not in the expected form"),
    (re.compile(r"Invalid enum value"), "choose one of the options"),
    (re.compile(r"Expected `datetime` with a timezone"), "needs a time zone"),
]


def _problem(path: str, message: str) -> FieldProblem:
    """A JSON-path problem as raised by msgspec or a service, named by its form input, in plain words."""
    name = path_to_name(path)
    for pattern, plain in _PLAIN:
        if m := pattern.search(message):
            groups = m.groupdict()
            if "f" in groups:
                name = f"{name}.{groups['f']}" if name else groups["f"]
            return FieldProblem(field=name, message=plain.format(**groups))
    return FieldProblem(field=name, message=message)


def path_to_name(path: str) -> str:
    """ "$.breathing.spo2_percent" -> "breathing.spo2_percent"; "$" -> "" (the form as a whole); a form
    input name is returned as it is."""
    if path == "$":
        return ""
    return path.removeprefix("$.") if path.startswith("$.") else path


def field_errors(problems: list[FieldProblem]) -> dict[str, str]:
    """Input name -> message, from FormInvalid's errors or a service's InvalidInput (JSON paths); "" holds the
    problems of the form as a whole. Two messages for one input are joined with "; "."""
    out: dict[str, str] = {}
    for p in problems:
        plain = _problem(p.field, p.message)
        out[plain.field] = f"{out[plain.field]}; {plain.message}" if plain.field in out else plain.message
    return out


def posted_text(data: dict[str, Any], name: str) -> str:
    """One text field of a posted form ("" when absent or not text; the first when sent twice)."""
    value = data.get(name, "")
    if isinstance(value, list):
        value = value[0] if value else ""
    return value if isinstance(value, str) else ""
