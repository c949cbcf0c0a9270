"""The package layout a newcomer relies on: layers, no import circles, no borrowed private names.

``analytic/`` and ``fem/`` never import each other (``compare/`` uses both); within the three
packages no two modules import each other, directly or round a loop (function-level imports
count, ``if TYPE_CHECKING:`` ones do not); and no module imports another module's underscore
names (a name two modules share is part of the package's internal interface and is named so).
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("analytic", "fem", "compare")


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for pkg in PACKAGES for p in sorted((ROOT / pkg).rglob("*.py"))}


def _typing_only(tree: ast.AST) -> set[int]:
    """ids of the nodes under ``if TYPE_CHECKING:`` (annotations only: not run, not a circle)."""
    return {id(n) for block in ast.walk(tree) if isinstance(block, ast.If)
            and isinstance(block.test, ast.Name) and block.test.id == "TYPE_CHECKING"
            for stmt in block.body for n in ast.walk(stmt)}


def _imports(path: Path, name: str) -> list[tuple[str, list[str]]]:
    """(imported module, imported names) of every import statement that runs (function-level
    ones included), relative ones resolved."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    tree = ast.parse(path.read_text())
    skip = _typing_only(tree)
    out = []
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*up, base] if base else up)
            out.append((base, [a.name for a in node.names]))
    return out


def _graph() -> dict[str, set[str]]:
    """Module -> the package modules it imports (``from pkg import mod`` counts as ``pkg.mod``)."""
    mods = _modules()
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for mod, path in mods.items():
        for target, names in _imports(path, mod):
            subs = {f"{target}.{n}" for n in names} & mods.keys()
            graph[mod] |= subs or ({target} & mods.keys())
            graph[mod] -= {mod}
    return graph


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph[m]):
            if state.get(n) == 1:
                return stack[stack.index(n):] + [n]
            if n not in state and (found := visit(n)):
                return found
        stack.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state and (found := visit(m)):
            return found
    return None


def test_analytic_and_fem_never_import_each_other():
    graph = _graph()
    bad = [(m, n) for m, targets in graph.items() for n in targets
           if {m.split(".")[0], n.split(".")[0]} == {"analytic", "fem"}]
    assert not bad, f"analytic/ and fem/ must not import each other: {bad}"


def test_no_import_cycles():
    cycle = _cycle(_graph())
    assert cycle is None, "import circle: " + " -> ".join(cycle or [])


def test_no_module_imports_another_modules_private_names():
    mods = _modules()
    bad = []
    for mod, path in mods.items():
        for target, names in _imports(path, mod):
            if target in mods and target != mod:
                bad += [f"{mod} imports {target}.{n}" for n in names
                        if n.startswith("_") and f"{target}.{n}" not in mods]
    assert not bad, "private names imported across modules:\n" + "\n".join(bad)


@pytest.mark.parametrize("graph, expected", [
    ({"a": {"b"}, "b": {"c"}, "c": {"a"}}, ["a", "b", "c", "a"]),
    ({"a": {"b"}, "b": {"c"}, "c": set()}, None),
])
def test_cycle_finder(graph, expected):
    assert _cycle(graph) == expected


def test_imports_resolve_relative_and_skip_typing_only(tmp_path):
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    path = pkg / "mod.py"
    path.write_text("from typing import TYPE_CHECKING\nfrom . import other\n"
                    "from .sub import _hidden\nif TYPE_CHECKING:\n    import pkg.late\n"
                    "def f():\n    import pkg.lazy\n")
    assert _imports(path, "pkg.mod") == [("typing", ["TYPE_CHECKING"]), ("pkg", ["other"]),
                                         ("pkg.sub", ["_hidden"]), ("pkg.lazy", [])]


def _layout_sections() -> dict[str, str]:
    text = (ROOT / "docs" / "layout.md").read_text()
    parts = re.split(r"^## (\S+)", text, flags=re.M)
    return {name.rstrip("/"): body for name, body in zip(parts[1::2], parts[2::2], strict=True)}


@pytest.mark.parametrize("package", PACKAGES)
def test_layout_doc_names_every_module_and_only_those(package):
    """docs/layout.md, the newcomer's map, lists each module and subpackage of the package
    and nothing that no longer exists."""
    section = _layout_sections()[package]
    on_disk = {p.name for p in (ROOT / package).glob("*.py") if p.name != "__init__.py"}
    on_disk |= {f"{p.name}/" for p in (ROOT / package).iterdir()
                if p.is_dir() and (p / "__init__.py").is_file()}
    named = set(re.findall(r"`(\w+\.py|\w+/)`", section))
    assert on_disk - named == set(), f"modules missing from docs/layout.md: {on_disk - named}"
    assert named - on_disk == set(), f"docs/layout.md names what is gone: {named - on_disk}"
