"""Renders docs/configuration.md from the field docstrings in schemas/config.py.

.venv/bin/python -m schemas.config_docs > docs/configuration.md
"""

from __future__ import annotations

import ast
import inspect
import typing

from schemas import config as config_module


def sections() -> dict[str, str]:
    """Class name -> TOML section, for every section of Config (so a new section cannot go undocumented)."""
    hints = typing.get_type_hints(config_module.Config)
    return {hints[name].__name__: name for name in config_module.Config.__struct_fields__}


def field_docs() -> dict[str, list[tuple[str, str, str]]]:
    """Class name -> [(field, default as written, docstring)], in source order."""
    tree = ast.parse(inspect.getsource(config_module))
    out: dict[str, list[tuple[str, str, str]]] = {}
    for node in tree.body:
        if not isinstance(node, ast.ClassDef):
            continue
        fields = []
        body = node.body
        for stmt, following in zip(body, [*body[1:], None], strict=True):
            if isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name):
                doc = ""
                if isinstance(following, ast.Expr) and isinstance(following.value, ast.Constant):
                    doc = " ".join(str(following.value.value).split())
                default = ast.unparse(stmt.value) if stmt.value is not None else ""
                fields.append((stmt.target.id, default, doc))
        out[node.name] = fields
    return out


def render() -> str:
    docs = field_docs()
    lines = [
        "# Configuration",
        "",
        "Generated from `schemas/config.py` by `python -m schemas.config_docs`; a test keeps it current.",
        "",
        "Settings come from a TOML file (`burnedge --config FILE`, example in `deploy/burnedge.example.toml`),",
        "then environment variables `BURNEDGE_<SECTION>_<FIELD>` (e.g. `BURNEDGE_GATEWAY_PORT=8443`; lists comma-separated),",
        "then command-line flags (`--db`, `--host`, `--port`). Invalid values stop the program with a message.",
        "",
    ]
    for cls, section in sections().items():
        lines += [f"## [{section}]", "", "| setting | default | meaning |", "|---|---|---|"]
        for name, default, doc in docs[cls]:
            lines.append(f"| `{name}` | `{default}` | {doc} |")
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    print(render(), end="")
