"""The import graph runs one way: schemas -> base -> processing, sync -> gateway, center -> the command line on top.

An AST walk over every module (imports inside functions included) finds each import of a project module; a module
may import its own layer or those below, never one above, never a sibling server, and no circle of modules, nor of
sibling packages (gateway.jobs and gateway.records, say), may form. A second test loads the burn center's app in a fresh interpreter and checks it pulls in no gateway code and no
OpenCV.
"""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from harness.processes import REPO

LAYERS = {"schemas": 0, "base": 1, "processing": 2, "sync": 2, "gateway": 3, "center": 3, "burnedge": 4}
"""Each top-level package's layer; a module imports only from its own package or from a lower layer."""
ALLOWED_ACROSS = {("sync", "processing")}
"""sync stands on processing where a case bundle needs the science's artifacts."""


def project_modules() -> dict[str, Path]:
    modules = {}
    for package in LAYERS:
        for path in (REPO / package).rglob("*.py"):
            name = ".".join(path.relative_to(REPO).with_suffix("").parts)
            modules[name.removesuffix(".__init__")] = path
    return modules


def imported(module: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The project modules `module` imports anywhere in its body."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = module.split(".")
                keep = len(parts) - node.level + (1 if path.name == "__init__.py" else 0)
                prefix = ".".join(parts[:keep] + ([node.module] if node.module else []))
            else:
                prefix = node.module or ""
            names = [f"{prefix}.{alias.name}" for alias in node.names] + [prefix]
        else:
            continue
        for name in names:
            while name and name not in modules:
                name = name.rpartition(".")[0]
            if name and name != module:
                found.add(name)
    return found


def import_graph() -> dict[str, set[str]]:
    modules = project_modules()
    return {name: imported(name, path, modules) for name, path in modules.items()}


def layer(module: str) -> tuple[str, int]:
    package = module.split(".")[0]
    return package, LAYERS[package]


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    wrong = []
    for source, targets in graph.items():
        (src_pkg, src_layer) = layer(source)
        for target in targets:
            (dst_pkg, dst_layer) = layer(target)
            if src_pkg == dst_pkg or (src_pkg, dst_pkg) in ALLOWED_ACROSS:
                continue
            if dst_layer >= src_layer:
                wrong.append(f"{source} imports {target} ({dst_pkg} is not below {src_pkg})")
    return sorted(wrong)


def module_circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan's algorithm, iterative)."""
    index, low, stack, on_stack, circles, counter = {}, {}, [], set(), [], 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    circles.append(sorted(component))
    return circles


def package_of(module: str, modules: dict[str, Path]) -> str:
    """The package a module lives in (a package's __init__ is the package itself)."""
    return module if modules[module].name == "__init__.py" else module.rpartition(".")[0]


def package_graph(graph: dict[str, set[str]], modules: dict[str, Path]) -> dict[str, set[str]]:
    """Package -> the packages its modules import, leaving out a package's own ancestors and descendants: a package
    uses what contains it (gateway.records reads gateway.dependencies) and composes what it contains (gateway.app
    wires gateway.records); siblings, and their descendants, must not import each other both ways."""
    packages: dict[str, set[str]] = {}
    for source, targets in graph.items():
        src = package_of(source, modules)
        packages.setdefault(src, set())
        for target in targets:
            dst = package_of(target, modules)
            if dst == src or dst.startswith(src + ".") or src.startswith(dst + "."):
                continue
            packages[src].add(dst)
            packages.setdefault(dst, set())
    return packages


def test_no_module_imports_from_a_layer_above_its_own():
    assert upward_imports(import_graph()) == []


def test_no_circle_of_modules_remains():
    assert module_circles(import_graph()) == []


def test_no_circle_of_packages_remains():
    assert module_circles(package_graph(import_graph(), project_modules())) == []


def test_the_package_check_sees_a_circle_between_sibling_packages_but_not_a_parent_and_its_child():
    modules = {
        name: Path(f"{name.replace('.', '/')}.py")
        for name in ("gateway.app", "gateway.dependencies", "gateway.jobs.runner", "gateway.services.support")
    }
    siblings = {
        "gateway.jobs.runner": {"gateway.services.support"},
        "gateway.services.support": {"gateway.jobs.runner"},
    }
    assert module_circles(package_graph(siblings, modules)) == [["gateway.jobs", "gateway.services"]]
    nested = {"gateway.app": {"gateway.services.support"}, "gateway.services.support": {"gateway.dependencies"}}
    assert module_circles(package_graph(nested, modules)) == []


def test_the_checks_see_an_upward_import_and_a_circle():
    graph = {"base.a": {"gateway.b"}, "gateway.b": {"base.a"}, "sync.c": {"processing.d"}, "processing.d": set()}
    assert upward_imports(graph) == ["base.a imports gateway.b (gateway is not below base)"]
    assert module_circles(graph) == [["base.a", "gateway.b"]]
    assert upward_imports({"processing.d": {"sync.c"}, "sync.c": set()}) != []
    assert upward_imports({"center.x": {"gateway.y"}, "gateway.y": set()}) != []


@pytest.mark.parametrize("module", ["center.app", "sync.sender", "base.web.account_controllers"])
def test_the_center_and_the_shared_layers_load_no_gateway_code_and_no_opencv(module: str):
    probe = f"import json, sys, {module}; print(json.dumps(sorted(sys.modules)))"
    loaded = json.loads(
        subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, cwd=REPO, check=True).stdout
    )
    assert module in loaded, "the probe did not load the module it checks"
    assert [m for m in loaded if m == "gateway" or m.startswith("gateway.")] == []
    assert "cv2" not in loaded


SQL_KEYWORD = re.compile(r"^\s*(SELECT|INSERT|UPDATE|DELETE|CREATE|DROP|ALTER|WITH|PRAGMA|REPLACE|VACUUM)\b")
SQL_CLAUSE = re.compile(r"\b(FROM|INTO|SET|TABLE|INDEX|VALUES|PRAGMA|VACUUM)\b")
FOREIGN_DATABASES = {
    "processing.reconstruction.colmap_database": "COLMAP's own feature database, read-only",
}
"""Modules that read a database burnedge does not own, so it has no storage module of burnedge's."""


def is_storage_module(module: str) -> bool:
    return "storage" in module.split(".") or module in FOREIGN_DATABASES


def sql_outside_storage(modules: dict[str, Path] | None = None) -> list[str]:
    """Each SQL statement (a string that reads as one) or `.execute` call outside a storage module, as
    "module:line"."""
    found = []
    for module, path in (modules or project_modules()).items():
        if is_storage_module(module):
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            text = None
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                text = node.value
            elif isinstance(node, ast.JoinedStr) and node.values and isinstance(node.values[0], ast.Constant):
                text = str(node.values[0].value)
            is_sql = text is not None and SQL_KEYWORD.match(text) and SQL_CLAUSE.search(text)
            is_call = (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr in ("execute", "executemany", "executescript")
            )
            if is_sql or is_call:
                found.append(f"{module}:{node.lineno}")
    return sorted(set(found))


def rows_outside_storage(modules: dict[str, Path] | None = None) -> list[str]:
    """Modules outside storage that name sqlite3.Row: untyped rows must not travel past the storage layer."""
    return sorted(
        module
        for module, path in (modules or project_modules()).items()
        if not is_storage_module(module) and "sqlite3.Row" in path.read_text()
    )


def test_sql_lives_only_in_storage_modules():
    assert sql_outside_storage() == []


def test_no_untyped_row_travels_past_the_storage_modules():
    assert rows_outside_storage() == []
