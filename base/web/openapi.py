"""The published OpenAPI document says what the gateway really accepts (tests/test_fuzz_api.py holds it to that).

Three things Litestar's generator leaves out or gets wrong for our msgspec Structs:
- every message refuses unknown fields (schemas/base.py Message): the document says so with
  `additionalProperties: false`, else a client, or a generator of clients, believes extra fields are fine;
- patterns are written for Python; the document carries their ECMA-262 form, as JSON Schema requires
  (schemas/export.py ecma_pattern; path parameters say so with `schema_extra`, gateway/records/http.py);
- a bound of zero on an optional number (`ge=0`, `gt=0`: weights, durations, flows) was dropped, Litestar testing
  the bound for truth, so the document allowed negative weights the gateway refuses.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import msgspec
from litestar._openapi.schema_generation.plugins.struct import StructSchemaPlugin
from litestar.openapi.spec import Schema

from schemas.export import ecma_pattern

if TYPE_CHECKING:
    from litestar._openapi.schema_generation import SchemaCreator
    from litestar.typing import FieldDefinition


def _publish_patterns(schema: object) -> None:
    """In a field's schema and those inside it (arrays, unions, maps); other Structs are references to their own."""
    if not isinstance(schema, Schema):
        return
    if isinstance(schema.pattern, str):
        schema.pattern = ecma_pattern(schema.pattern)
    for child in [
        schema.items,
        schema.additional_properties,
        *(schema.one_of or []),
        *(schema.any_of or []),
        *(schema.all_of or []),
    ]:
        _publish_patterns(child)


_BOUNDS = {"ge": "minimum", "gt": "exclusive_minimum", "le": "maximum", "lt": "exclusive_maximum"}


def _publish_bounds(schema: object, field_type: msgspec.inspect.Type) -> None:
    """Numeric bounds of an optional field that the generator left out (those equal to zero)."""
    if isinstance(field_type, msgspec.inspect.UnionType):
        present = [t for t in field_type.types if not isinstance(t, msgspec.inspect.NoneType)]
        field_type = present[0] if len(present) == 1 else field_type
    if isinstance(field_type, msgspec.inspect.Metadata):
        field_type = field_type.type
    if not isinstance(schema, Schema) or not isinstance(
        field_type, (msgspec.inspect.IntType, msgspec.inspect.FloatType)
    ):
        return
    for bound, keyword in _BOUNDS.items():
        value = getattr(field_type, bound)
        if value is not None and getattr(schema, keyword) is None:
            setattr(schema, keyword, value)


class ClosedStructSchemaPlugin(StructSchemaPlugin):
    """Litestar's Struct schema, closed to unknown fields where the Struct is, with ECMA-262 patterns and every
    numeric bound."""

    def to_openapi_schema(self, field_definition: FieldDefinition, schema_creator: SchemaCreator) -> Schema:
        schema = super().to_openapi_schema(field_definition, schema_creator)
        info = msgspec.inspect.type_info(field_definition.type_)
        if info.forbid_unknown_fields:
            schema.additional_properties = False
        for field in info.fields:
            prop = (schema.properties or {}).get(field.encode_name)
            _publish_patterns(prop)
            _publish_bounds(prop, field.type)
        return schema
