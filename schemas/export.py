"""Writes JSON Schema for every public message, so a phone team can generate its client.

Patterns are written for Python, where msgspec searches them (`\\A...\\Z` anchors a whole string). JSON Schema
patterns are ECMA-262: there `\\A` is an error in unicode mode and `^...$` already anchors the whole string, so
exported schemas (and the gateway's OpenAPI document, base/web/openapi.py) carry that form.
"""

from __future__ import annotations

import importlib
import json
import pkgutil
from pathlib import Path

import msgspec

import schemas
from schemas.base import Frozen, Message

_SKIP_MODULES = {"schemas.export", "schemas.config", "schemas.encounter_snapshot"}
"""Not messages: the exporter, the configuration (docs/configuration.md) and the encounter snapshot, an in-memory
reading that never travels as it is."""


def public_messages() -> list[type[msgspec.Struct]]:
    """Every Struct defined in the schemas package, except the two abstract bases."""
    found: dict[str, type[msgspec.Struct]] = {}
    for info in pkgutil.iter_modules(schemas.__path__, "schemas."):
        if info.name in _SKIP_MODULES:
            continue
        module = importlib.import_module(info.name)
        for value in vars(module).values():
            if (
                isinstance(value, type)
                and issubclass(value, msgspec.Struct)
                and value not in (Message, Frozen)
                and value.__module__ == module.__name__
            ):
                found[value.__name__] = value
    return [found[name] for name in sorted(found)]


def ecma_pattern(pattern: str) -> str:
    """A Python pattern anchored with \\A and \\Z as the ECMA-262 pattern that matches the same strings."""
    if pattern.startswith(r"\A"):
        pattern = "^" + pattern[2:]
    if pattern.endswith(r"\Z") and not pattern.endswith(r"\\Z"):
        pattern = pattern[:-2] + "$"
    return pattern


def _ecma_patterns(node: object) -> object:
    if isinstance(node, dict):
        return {
            k: ecma_pattern(v) if k == "pattern" and isinstance(v, str) else _ecma_patterns(v) for k, v in node.items()
        }
    if isinstance(node, list):
        return [_ecma_patterns(v) for v in node]
    return node


def export_json_schemas(out_dir: Path) -> list[Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for struct in public_messages():
        path = out_dir / f"{struct.__name__}.json"
        schema = _ecma_patterns(msgspec.json.schema(struct))
        schema.setdefault("$schema", "https://json-schema.org/draft/2020-12/schema")
        path.write_text(json.dumps(schema, indent=2, sort_keys=True) + "\n")
        written.append(path)
    index = {"messages": [p.stem for p in written]}
    (out_dir / "index.json").write_text(json.dumps(index, indent=2) + "\n")
    return written
