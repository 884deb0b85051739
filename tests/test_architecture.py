"""The package's import graph: dependencies run one way and no module imports another that
imports it back (directly or through others).

Layers, lowest first: a module may import only from its own package or lower ones. Imports used
only for annotations (inside ``if TYPE_CHECKING:``) are not dependencies and are not counted.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "src" / "odorloc"

LAYERS = [
    "core",
    "geometry",
    "models",
    "wind",
    "plume",
    "sensors",
    "platforms",
    "world",
    "inference",
    "planning",
    "behaviours",
    "searchers",
    "scenarios",
    "engine",
    "viz",
    "checks",
    "envs",
    "replay",
    "experiments",
    "papers",
    "cli",
]


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING"
    )


def _imports(path: Path) -> set[str]:
    """Odorloc modules imported by a file (type-only imports left out)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_type_checking(node):
            for sub in node.body:
                for inner in ast.walk(sub):
                    skip.add(id(inner))
    me = _module_name(path)
    pkg = me.split(".") if path.name == "__init__.py" else me.split(".")[:-1]
    out: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("odorloc")}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg[: len(pkg) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.startswith("odorloc"):
                out.add(mod)
                out |= {f"{mod}.{a.name}" for a in node.names}
    return out


def _graph() -> dict[str, set[str]]:
    files = sorted(ROOT.rglob("*.py"))
    mods = {_module_name(f): f for f in files}
    g: dict[str, set[str]] = {}
    for m, f in mods.items():
        deps = set()
        for imp in _imports(f):
            c = imp
            while c and c not in mods:
                c = c.rpartition(".")[0]
            if c and c != m and c != "odorloc":
                deps.add(c)
        g[m] = deps
    return g


def _layer(mod: str) -> int:
    parts = mod.split(".")
    if len(parts) == 1:
        return -1
    return LAYERS.index(parts[1])


GRAPH = _graph()


def test_every_package_has_a_layer() -> None:
    for m in GRAPH:
        parts = m.split(".")
        if len(parts) > 1:
            assert parts[1] in LAYERS, f"{m}: package {parts[1]!r} has no place in LAYERS"


def test_dependencies_run_one_way() -> None:
    bad = [
        f"{m} ({m.split('.')[1]}) imports {d} ({d.split('.')[1]})"
        for m, deps in GRAPH.items()
        for d in deps
        if _layer(d) > _layer(m)
    ]
    assert not bad, "upward imports:\n" + "\n".join(sorted(bad))


def test_no_import_cycles() -> None:
    """Tarjan's strongly connected components over modules: every component is one module."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    cycles: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in GRAPH.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    assert not cycles, f"import cycles: {cycles}"


def test_the_checker_sees_an_upward_import(tmp_path: Path) -> None:
    f = tmp_path / "odorloc" / "core" / "bad.py"
    f.parent.mkdir(parents=True)
    f.write_text("from odorloc.searchers.base import Searcher\n")
    global ROOT
    saved = ROOT
    try:
        ROOT = tmp_path / "odorloc"
        assert "odorloc.searchers.base.Searcher" in _imports(
            f
        ) or "odorloc.searchers.base" in _imports(f)
    finally:
        ROOT = saved


@pytest.mark.parametrize("family", ["wind", "plume", "searcher", "resampler", "model"])
def test_components_are_found_without_an_import_list(family: str) -> None:
    """Every module of the component packages registers itself by being discovered."""
    from odorloc.core import registry

    assert registry.names(family)
