"""A GET request's query string read into the message it describes: one Struct is the definition of a list's
filters for the API and the pages alike."""

from __future__ import annotations

import re
from typing import TypeVar

import msgspec
from litestar import Request

from schemas.errors import InvalidInput
from schemas.problem import FieldProblem

T = TypeVar("T", bound=msgspec.Struct)
_AT_PATH = re.compile(r"^(?P<msg>.*?)(?: - at `\$\.(?P<field>[^`]*)`)?$", re.S)
_UNKNOWN = re.compile(r"Object contains unknown field `(?P<name>[^`]*)`")


def query_struct(request: Request, struct_type: type[T]) -> T:
    """The request's query parameters as `struct_type`, converted from text (a number, a date, true/false). A
    parameter left empty (a form's blank choice) counts as not given, and a repeated one as its last value.
    InvalidInput names the parameter that is wrong or that the list does not take."""
    given = {name: values[-1] for name, values in request.query_params.dict().items() if values[-1].strip()}
    try:
        return msgspec.convert(given, struct_type, strict=False)
    except msgspec.ValidationError as exc:
        m = _AT_PATH.match(str(exc))
        unknown = _UNKNOWN.match(m["msg"])
        if unknown:
            name, message = unknown["name"], "not a parameter this list takes"
        else:
            name, message = m["field"] or "", m["msg"].replace("RFC3339 encoded date", "date (YYYY-MM-DD)")
        raise InvalidInput(
            f"query parameter `{name}`: {message}", errors=[FieldProblem(field=f"$.{name}", message=message)]
        ) from exc
