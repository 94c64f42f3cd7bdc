"""The configuration file a restore writes: the backed-up gateway's settings, pointing at the restored state."""

from __future__ import annotations

import json
from pathlib import Path

FOLDERS = {
    "media": "burnedge-media",
    "analyses": "burnedge-analyses",
    "outbox": "burnedge-outbox",
    "keys": "burnedge-keys",
}
"""Top folder in the archive -> folder in the restore target (the default names beside the database)."""


def state_paths(into: Path, database_name: str) -> dict[str, dict[str, str]]:
    root = into.resolve()
    return {
        "gateway": {"database": str(root / database_name)},
        "uploads": {"data_dir": str(root / FOLDERS["media"])},
        "jobs": {"work_dir": str(root / FOLDERS["analyses"])},
        "sync": {"keys_dir": str(root / FOLDERS["keys"]), "outbox_dir": str(root / FOLDERS["outbox"])},
    }


def render(settings: dict[str, dict[str, object]], into: Path, database_name: str, created_at: str) -> str:
    merged: dict[str, dict[str, object]] = {section: dict(values) for section, values in settings.items()}
    for section, values in state_paths(into, database_name).items():
        merged.setdefault(section, {}).update(values)
    lines = [
        f"# Written by `burnedge restore` from a backup made at {created_at}.",
        "# The gateway's settings as they were, with the state's paths pointing at this restore.",
        "# Settings that name files outside the state (TLS, model, recipient key) point where they did: check them.",
        "# [backup] folder is not carried over: set it once this copy is the clinic's gateway.",
    ]
    for section in sorted(merged, key=lambda s: (s != "gateway", s)):
        lines += ["", f"[{section}]"]
        lines += [f"{field} = {_value(value)}" for field, value in merged[section].items()]
    return "\n".join(lines) + "\n"


def _value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a valid TOML basic string
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    raise TypeError(f"setting of type {type(value).__name__} cannot be written to TOML")
