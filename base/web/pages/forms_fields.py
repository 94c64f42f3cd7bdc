"""The fields of a browser form, built from a msgspec Struct type, ready for the `render_fields` macro.

base/web/templates/macros/fields.html renders them; values come from a stored record or from what the browser
posted (to show a form again, as typed, next to its errors).
"""

from __future__ import annotations

import datetime as dt
import re
from collections.abc import Collection, Mapping
from typing import Any

import msgspec

from base.web.pages.clinic_time import ClinicClock, offset_text
from base.web.pages.forms_spec import TRISTATE_CHOICES, FieldSpec, Kind, struct_fields
from base.web.pages.forms_wire import checked, compact_rows, encode, first, number_text, read_raw, row_indices

_UNSAFE_ID = re.compile(r"[^A-Za-z0-9_-]+")


class FormField(msgspec.Struct, frozen=True, kw_only=True):
    """One control (or a fieldset of them) of a form."""

    name: str
    """The input name: "weight_kg", "airway.patent", "medications[0].name"."""
    id: str
    """HTML id: letters, digits, "-" and "_" only."""
    label: str
    kind: Kind
    required: bool = False
    min: str | None = None
    max: str | None = None
    step: str | None = None
    """"1" for whole numbers, "any" for decimals; on a datetime, set when the value carries seconds."""
    maxlength: int | None = None
    choices: tuple[tuple[str, str], ...] = ()
    """(value, label) of a select's options or a tristate's radios; "" is "not recorded" / "choose one"."""
    value: str | bool = ""
    """The text the input shows; a bool for a checkbox."""
    help: str | None = None
    error: str | None = None
    warning: str | None = None
    """A value that is allowed but unusual (a vital sign outside the range for the patient's age): shown beside
    the field; saved once the person confirms it."""
    children: list[FormField] = []
    """A group's fields."""
    rows: list[list[FormField]] = []
    """A list's rows (each a list of fields), blank rows to add more at the end."""
    scalar_rows: bool = False
    """A list of plain values: each row is one field, labelled with its row number."""
    item_label: str = ""
    """A list's item in the singular ("Medication"): its rows are "Medication 1", "Medication 2"."""
    blank_from: int = 0
    """The index of the list's first blank row (rows from it on are there to add more; a script shows one at a
    time behind an "Add another" button)."""
    zone_offset: int | None = None
    """On a datetime read in the clinic's zone: its offset from UTC in minutes (east positive), which the page's
    script compares with the phone's to say when the phone is set to another zone."""
    zone_text: str = ""
    """That offset as people read it ("UTC+03:00")."""

    @property
    def described_by(self) -> str:
        """The ids of the help and the error, for aria-describedby ("" when there are none)."""
        ids = ([f"{self.id}-help"] if self.help else []) + ([f"{self.id}-error"] if self.error else [])
        ids += [f"{self.id}-warning"] if self.warning else []
        return " ".join(ids)


class _Context(msgspec.Struct, frozen=True):
    posted: dict[str, list[str]]
    errors: Mapping[str, str]
    skip: Collection[str]
    blank_rows: int
    tz: dt.tzinfo | None
    id_prefix: str
    clock: ClinicClock | None = None
    in_row: bool = False
    """Inside a list row: nothing is required of the browser, since a row left blank is dropped."""


def form_fields(
    struct_type: type,
    *,
    value: msgspec.Struct | None = None,
    raw: Any = None,
    errors: Mapping[str, str] | None = None,
    skip: Collection[str] = frozenset(),
    blank_rows: int = 4,
    tz: dt.tzinfo | None = None,
    id_prefix: str = "field",
    clock: ClinicClock | None = None,
) -> list[FormField]:
    """The fields of a form for `struct_type`.

    value: a stored record to show (None: a new one, every field at its default). raw: what the browser posted
    (a FormMultiDict or name -> list of str), shown as typed; it wins over `value`. errors: input name -> message,
    from `field_errors`. skip: input names the page fills itself ("encounter_id"). blank_rows: empty rows added to
    each list. tz: the zone datetime inputs show wall time in (None: this machine's). clock: the clinic's clock,
    which sets tz and names the zone and the tolerance on every datetime field ("Time of injury (Africa/Nairobi,
    UTC+03:00)").
    """
    if clock is not None:
        tz = clock.tz
    specs = [s for s in struct_fields(struct_type) if s.name not in skip]
    posted = compact_rows(specs, read_raw(raw)) if raw is not None else encode(specs, value, tz)
    context = _Context(posted, errors or {}, skip, blank_rows, tz, id_prefix, clock)
    return _fields(specs, "", context)


def _fields(specs: list[FieldSpec] | tuple[FieldSpec, ...], prefix: str, ctx: _Context) -> list[FormField]:
    return [_field(spec, prefix + spec.name, ctx) for spec in specs if prefix + spec.name not in ctx.skip]


def _field(spec: FieldSpec, name: str, ctx: _Context) -> FormField:
    common = {
        "name": name,
        "id": f"{ctx.id_prefix}-{_UNSAFE_ID.sub('-', name).strip('-')}",
        "label": spec.label,
        "kind": spec.kind,
        "required": spec.required and not ctx.in_row,
        "help": spec.help,
        "error": ctx.errors.get(name),
    }
    if spec.kind == "group":
        return FormField(**common, children=_fields(spec.children, name + ".", ctx))
    if spec.kind == "list":
        return _list_field(spec, name, ctx, common)
    if spec.kind == "checkbox":
        return FormField(**common, value=checked(ctx.posted.get(name, ())))
    text = first(ctx.posted, name)
    if spec.kind == "tristate":
        return FormField(**common, value=text, choices=TRISTATE_CHOICES)
    if spec.kind == "select":
        return FormField(**common, value=text, choices=spec.choices)
    if spec.kind == "number":
        low = spec.ge if spec.ge is not None else spec.gt
        high = spec.le if spec.le is not None else spec.lt
        return FormField(
            **common,
            value=text,
            min=None if low is None else number_text(low),
            max=None if high is None else number_text(high),
            step="1" if spec.number == "int" else "any",
        )
    if spec.kind == "datetime":
        return _datetime_field(common, text, ctx.clock)
    return FormField(**common, value=text, maxlength=spec.max_length)


def _datetime_field(common: dict[str, Any], text: str, clock: ClinicClock | None) -> FormField:
    """A datetime input; with the clinic's clock, labelled with its zone and offset and helped with the tolerance."""
    if clock is None:
        return FormField(**common, value=text, step=_datetime_step(text))
    offset = clock.offset()
    label = f"{common['label']} ({clock.label()})"
    help_text = " ".join(filter(None, [common["help"], clock.help()]))
    return FormField(
        **{**common, "label": label, "help": help_text},
        value=text,
        step=_datetime_step(text),
        zone_offset=round(offset.total_seconds() / 60),
        zone_text=offset_text(offset),
    )


def _datetime_step(text: str) -> str | None:
    """The browser's default step is a minute: a value with seconds would fail its own validation."""
    seconds = text.partition("T")[2][6:]
    if not seconds or seconds.strip("0:.") == "":
        return None
    return "1" if "." not in seconds else "any"


def _list_field(spec: FieldSpec, name: str, ctx: _Context, common: dict[str, Any]) -> FormField:
    item = spec.item
    count = len(row_indices(ctx.posted, name))
    rows = []
    for i in range(count + ctx.blank_rows):
        head = f"{name}[{i}]"
        posted = ctx.posted if i < count else encode_row(item, head, ctx.tz)
        row_ctx = msgspec.structs.replace(ctx, posted=posted, in_row=True)
        if item.kind == "group":
            rows.append(_fields(item.children, head + ".", row_ctx))
        else:
            label = f"{singular(spec.label)} {i + 1}"
            rows.append([msgspec.structs.replace(_field(item, head, row_ctx), label=label)])
    return FormField(
        **common, rows=rows, scalar_rows=item.kind != "group", item_label=singular(spec.label), blank_from=count
    )


def singular(label: str) -> str:
    """ "Medications" -> "Medication", "Significant comorbidities" -> "Significant comorbidity": how one row of a
    list is named."""
    if label.endswith("ies"):
        return label[:-3] + "y"
    if label.endswith("s") and not label.endswith("ss"):
        return label[:-1]
    return label


def encode_row(item: FieldSpec, head: str, tz: dt.tzinfo | None) -> dict[str, list[str]]:
    """The inputs of a new list row, at their defaults."""
    if item.kind == "group":
        return encode(item.children, None, tz, head + ".")
    return {}


def errors_in(fields: list[FormField], context: str = "") -> list[FormField]:
    """Every field with an error, depth first, labelled with where it is ("Medication 2: Name"), for an error
    summary."""
    out = []
    for f in fields:
        label = f"{context}{f.label}"
        if f.error:
            out.append(msgspec.structs.replace(f, label=label))
        out += errors_in(f.children, f"{label}: ")
        for n, row in enumerate(f.rows, start=1):
            out += errors_in(row, context if f.scalar_rows else f"{context}{f.item_label} {n}: ")
    return out


def with_warnings(fields: list[FormField], warnings: Mapping[str, str]) -> list[FormField]:
    """The fields with each warning (by field name) set beside its field, groups included."""
    if not warnings:
        return fields
    return [
        msgspec.structs.replace(
            f, warning=warnings.get(f.name, f.warning), children=with_warnings(f.children, warnings)
        )
        for f in fields
    ]
