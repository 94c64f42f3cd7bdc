"""What a browser form needs to know about each field of a msgspec Struct, read from the Struct itself.

The schemas are the single source of a form's fields, limits and messages: the kind of control, bounds, length,
choices and default come from `msgspec.inspect.type_info`, the label from the field name, the help from the
attribute's docstring (the string written under it, as schemas/config_docs.py reads them).
"""

from __future__ import annotations

import ast
import functools
import inspect
import textwrap
from typing import Any, Literal

import msgspec
from msgspec import inspect as mi

from schemas.burn_chart import REGION_NAMES

Kind = Literal["text", "textarea", "number", "select", "checkbox", "tristate", "date", "datetime", "group", "list"]
TEXTAREA_OVER = 200
"""Strings allowed more characters than this get a multi-line box."""
LABELS = {"custom_ml_per_kg_per_percent": "Custom formula (mL/kg/%TBSA)"}
"""Whole-name labels, where the name made human would read badly."""
UNITS = {
    "_percent": "(%)",
    "_per_min": "(/min)",
    "_l_per_min": "(L/min)",
    "_mmhg": "(mmHg)",
    "_kg": "(kg)",
    "_cm": "(cm)",
    "_c": "(°C)",
    "_ml": "(mL)",
    "_s": "(seconds)",
    "_mmol_l": "(mmol/L)",
    "_v": "(volts)",
    "_years": "(years)",
    "_minutes": "(minutes)",
}
"""Field-name endings that are units: "spo2_percent" reads "SpO2 (%)"; a unit of one letter is written out."""
WORDS = {
    "spo2": "SpO2",
    "gcs": "GCS",
    "bp": "BP",
    "iv": "IV",
    "avpu": "AVPU",
    "hiv": "HIV",
    "tbsa": "TBSA",
    "abls": "ABLS",
    "id": "ID",
}
"""Abbreviations written as clinicians write them."""
CHOICE_LABELS = {("AirwayIntervention", "none"): "No intervention"}
"""(enum class name, value) -> a select option's label, where the value made human would read badly."""
YES, NO = "yes", "no"
NOT_RECORDED, NOT_CHOSEN, UNKNOWN = "Not recorded", "Not chosen", "unknown"
"""The blank option of a select; UNKNOWN: the default value that means nothing was recorded."""
TRISTATE_CHOICES = ((YES, "Yes"), (NO, "No"), ("", NOT_RECORDED))


def human(name: str) -> str:
    """A field name or enum value made human: breath_sounds -> "Breath sounds", gcs_eye -> "GCS eye"."""
    words = [WORDS.get(w, w) for w in name.split("_") if w]
    text = " ".join(words)
    return text[:1].upper() + text[1:]


def label_for(name: str) -> str:
    if name in LABELS:
        return LABELS[name]
    for suffix in sorted(UNITS, key=len, reverse=True):
        if name.endswith(suffix) and len(name) > len(suffix):
            return f"{human(name[: -len(suffix)])} {UNITS[suffix]}"
    return human(name)


@functools.cache
def attribute_docs(cls: type) -> dict[str, str]:
    """Field name -> the docstring written under it, for the class and its bases (the class's own win)."""
    docs: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        if klass.__module__ in ("builtins", "msgspec"):
            continue
        try:
            tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
        except (OSError, TypeError):
            continue  # no source (built at run time): no help texts
        body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
        for stmt, following in zip(body, [*body[1:], None], strict=True):
            if not (isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name)):
                continue
            if isinstance(following, ast.Expr) and isinstance(following.value, ast.Constant):
                docs[stmt.target.id] = " ".join(str(following.value.value).split())
    return docs


class FieldSpec(msgspec.Struct, frozen=True, kw_only=True):
    """One field as a form sees it; `children` for a nested Struct, `item` for a list's elements."""

    name: str
    label: str
    kind: Kind
    optional: bool = False
    required: bool = False
    """No default and not optional: the form must give it."""
    has_default: bool = False
    default: Any = None
    number: Literal["int", "float"] | None = None
    ge: float | None = None
    gt: float | None = None
    le: float | None = None
    lt: float | None = None
    min_length: int | None = None
    max_length: int | None = None
    pattern: str | None = None
    choices: tuple[tuple[str, str], ...] = ()
    help: str | None = None
    children: tuple[FieldSpec, ...] = ()
    item: FieldSpec | None = None


@functools.cache
def struct_fields(struct_type: type) -> tuple[FieldSpec, ...]:
    """The form fields of a Struct type, in declaration order."""
    info = mi.type_info(struct_type)
    if not isinstance(info, mi.StructType):
        raise TypeError(f"{struct_type!r} is not a msgspec Struct")
    docs = attribute_docs(struct_type)
    return tuple(_field_spec(field, docs.get(field.name)) for field in info.fields)


def _field_spec(field: mi.Field, help_text: str | None) -> FieldSpec:
    if field.default is not mi.NODEFAULT:
        default = field.default
    elif field.default_factory is not mi.NODEFAULT:
        default = field.default_factory()
    else:
        default = None
    return _spec(field.name, field.type, help_text=help_text, has_default=not field.required, default=default)


def _unwrap(t: mi.Type) -> mi.Type:
    while isinstance(t, mi.Metadata):
        t = t.type
    return t


def _spec(name: str, t: mi.Type, *, help_text: str | None, has_default: bool, default: Any) -> FieldSpec:
    t = _unwrap(t)
    optional = False
    if isinstance(t, mi.UnionType):
        rest = [_unwrap(x) for x in t.types if not isinstance(x, mi.NoneType)]
        if len(rest) != 1 or len(rest) == len(t.types):
            raise TypeError(f"field {name!r}: a form cannot show a union of several types")
        optional, t = True, rest[0]
    common = {
        "name": name,
        "label": label_for(name),
        "help": help_text,
        "optional": optional,
        "required": not (optional or has_default),
        "has_default": has_default,
        "default": default,
    }
    if isinstance(t, mi.BoolType):
        return FieldSpec(**{**common, "required": False}, kind="tristate" if optional else "checkbox")
    if isinstance(t, (mi.IntType, mi.FloatType)):
        number = "int" if isinstance(t, mi.IntType) else "float"
        return FieldSpec(**common, kind="number", number=number, ge=t.ge, gt=t.gt, le=t.le, lt=t.lt)
    if isinstance(t, mi.StrType):
        kind = "textarea" if t.max_length is not None and t.max_length > TEXTAREA_OVER else "text"
        return FieldSpec(**common, kind=kind, min_length=t.min_length, max_length=t.max_length, pattern=t.pattern)
    if isinstance(t, (mi.EnumType, mi.LiteralType)):
        values = [str(m.value) for m in t.cls] if isinstance(t, mi.EnumType) else [str(v) for v in t.values]
        owner = t.cls.__name__ if isinstance(t, mi.EnumType) else ""
        choices = _choices(
            values, optional, common["required"], default if has_default and not optional else None, owner
        )
        if choices[0][1] == NOT_CHOSEN:
            saved = dict(choices)[str(default)]
            common["help"] = " ".join(filter(None, [help_text, f'Left as not chosen, "{saved}" is saved.']))
        return FieldSpec(**common, kind="select", choices=choices)
    if isinstance(t, mi.DateType):
        return FieldSpec(**common, kind="date")
    if isinstance(t, mi.DateTimeType):
        return FieldSpec(**common, kind="datetime")
    if isinstance(t, mi.StructType) and not optional:
        return FieldSpec(**common, kind="group", children=struct_fields(t.cls))
    if isinstance(t, mi.ListType) and not optional:
        item = _spec(name, t.item_type, help_text=None, has_default=False, default=None)
        if item.kind == "list":
            raise TypeError(f"field {name!r}: a form cannot show a list of lists")
        return FieldSpec(**common, kind="list", item=item, min_length=t.min_length, max_length=t.max_length)
    raise TypeError(f"field {name!r}: a form cannot show {type(t).__name__}")


def _choices(
    values: list[str], optional: bool, required: bool, default: Any, owner: str = ""
) -> tuple[tuple[str, str], ...]:
    """A select's options, a blank one first: no form pre-selects a value the person did not choose. Left blank, an
    optional field is not recorded, a field with a default gets it ("unknown": not recorded), a required one is
    refused."""
    # a region by its name, not its code
    choices = [(v, CHOICE_LABELS.get((owner, v)) or REGION_NAMES.get(v) or human(v)) for v in values]
    if optional:
        choices.insert(0, ("", NOT_RECORDED))
    elif required:
        choices.insert(0, ("", "Choose one"))
    else:
        choices.insert(0, ("", NOT_RECORDED if str(default) == UNKNOWN else NOT_CHOSEN))
    return tuple(choices)
