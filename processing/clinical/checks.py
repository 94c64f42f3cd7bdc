"""The input checks every calculator shares: real numbers in range, aware times, enum members.

Each check returns the value in its checked form or raises schemas.errors.InvalidInput with
a message a clinician can act on. Given `field` (a JSON path such as "$.entries[2].fraction"),
the error also carries a FieldProblem for that field, and its message names the field.
"""

from __future__ import annotations

import datetime as dt
import enum
import math
from typing import TypeVar

from schemas.base import AGE_MAX_YEARS, HEIGHT_MAX_CM, HEIGHT_MIN_CM, WEIGHT_MAX_KG
from schemas.errors import InvalidInput
from schemas.problem import FieldProblem

E = TypeVar("E", bound=enum.Enum)


def invalid(message: str, field: str | None = None) -> InvalidInput:
    """InvalidInput with this message; naming the field and carrying a FieldProblem when given one."""
    if field is None:
        return InvalidInput(message)
    return InvalidInput(f"{message} ({field})", errors=[FieldProblem(field=field, message=message)])


def _range(lo: float, hi: float, lo_open: bool, unit: str) -> str:
    unit = f" {unit}" if unit else ""
    if math.isinf(hi):
        return f"above {lo:g}{unit}" if lo_open else f"{lo:g}{unit} or more"
    return f"above {lo:g}, up to {hi:g}{unit}" if lo_open else f"from {lo:g} to {hi:g}{unit}"


def finite(
    value: object,
    what: str,
    lo: float,
    hi: float = math.inf,
    *,
    lo_open: bool = False,
    unit: str = "",
    field: str | None = None,
) -> float:
    """`value` as a float if it is a real number (not a bool, NaN or infinity) within [lo, hi].

    lo_open makes the range (lo, hi]. `what` names the quantity in the message
    ("weight", "burned fraction of genitalia"); `unit` follows the value ("kg").
    """
    expected = _range(lo, hi, lo_open, unit)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise invalid(f"{what} {value!r} is not a number: enter a number {expected}", field)
    if not (lo < value if lo_open else lo <= value) or not value <= hi:
        shown = f"{value:g} {unit}" if unit else f"{value:g}"
        raise invalid(f"{what} {shown} is impossible: enter a number {expected}", field)
    return float(value)


def aware(value: object, what: str, *, field: str | None = None) -> dt.datetime:
    """`value` if it is a datetime with a UTC offset; a clinical time without one is ambiguous."""
    if not isinstance(value, dt.datetime):
        raise invalid(f"{what} {value!r} is not a date and time", field)
    if value.tzinfo is None or value.utcoffset() is None:
        raise invalid(f"{what} {value.isoformat()} has no UTC offset: record it with its time zone", field)
    return value


def member(enum_cls: type[E], value: object, what: str, *, field: str | None = None) -> E:
    """`value` as a member of `enum_cls` (a member or its value)."""
    try:
        return enum_cls(value)
    except ValueError:
        allowed = ", ".join(f"'{m.value}'" for m in enum_cls)
        raise invalid(f"unknown {what} {value!r}: use one of {allowed}", field) from None


def check_age(age_years: object, *, field: str | None = None) -> float:
    """The age in years as a float, or InvalidInput if no patient can be that old."""
    return finite(age_years, "age", 0, AGE_MAX_YEARS, unit="years", field=field)


def check_weight(weight_kg: object, *, field: str | None = None) -> float:
    """The weight in kg as a float, or InvalidInput if no patient can weigh that."""
    return finite(weight_kg, "weight", 0, WEIGHT_MAX_KG, lo_open=True, unit="kg", field=field)


def check_height(height_cm: object, *, field: str | None = None) -> float:
    """The height in cm as a float, or InvalidInput if no patient can be that tall."""
    return finite(height_cm, "height", HEIGHT_MIN_CM, HEIGHT_MAX_CM, unit="cm", field=field)


def check_fraction(fraction: object, where: str, *, field: str | None = None) -> float:
    """A burned fraction (0 to 1) of a region or group."""
    return finite(fraction, f"burned fraction of {where}", 0, 1, field=field)


class Problems:
    """Gathers every problem of one record, to report them together in one InvalidInput."""

    def __init__(self) -> None:
        self.errors: list[FieldProblem] = []

    def add(self, field: str, message: str) -> None:
        self.errors.append(FieldProblem(field=field, message=message))

    def check(self, fn, *args, **kwargs):
        """fn(*args, **kwargs), or None with its problems recorded if it raises InvalidInput."""
        try:
            return fn(*args, **kwargs)
        except InvalidInput as exc:
            self.errors += exc.errors or [FieldProblem(field="$", message=exc.detail)]
            return None

    def raise_if_any(self, what: str) -> None:
        """InvalidInput naming every problem found, e.g. "burn chart: ... ($.entries[2].fraction)"."""
        if self.errors:
            fields: dict[str, list[str]] = {}
            for p in self.errors:
                fields.setdefault(p.message, []).append(p.field)
            listed = "; ".join(f"{message} ({', '.join(at)})" for message, at in fields.items())
            raise InvalidInput(f"{what}: {listed}", errors=list(self.errors))
