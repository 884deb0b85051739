"""The package's import graph: dependencies run one way and no module imports another that
imports it back (directly or through others).

:data:`LAYERS` is the one statement of the layer order, lowest first: a module may import only
from its own package or lower ones. ARCHITECTURE.md's layer table is checked against it (and the
README's chain of layers, where it has one). Imports used only for annotations (inside ``if
TYPE_CHECKING:``) are not dependencies and are not counted. The checkers are shown to catch an
upward import, a cycle and an unplaced package planted in a copy of the source tree.
"""

from __future__ import annotations

import ast
import re
import shutil
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


def _module_name(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING"
    )


def _imports(path: Path, root: Path = ROOT) -> set[str]:
    """Odorloc modules imported by a file (type-only imports left out)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_type_checking(node):
            for sub in node.body:
                for inner in ast.walk(sub):
                    skip.add(id(inner))
    me = _module_name(path, root)
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


def import_graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the odorloc modules it imports, for the package tree at ``root``."""
    files = sorted(root.rglob("*.py"))
    mods = {_module_name(f, root): f for f in files}
    g: dict[str, set[str]] = {}
    for m, f in mods.items():
        deps = set()
        for imp in _imports(f, root):
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


def unplaced(graph: dict[str, set[str]]) -> list[str]:
    """Modules of a package that has no place in :data:`LAYERS`."""
    return sorted(m for m in graph if len(m.split(".")) > 1 and m.split(".")[1] not in LAYERS)


def upward_imports(graph: dict[str, set[str]]) -> list[str]:
    """Every import of a module from a higher layer, as readable lines."""
    return sorted(
        f"{m} ({m.split('.')[1]}) imports {d} ({d.split('.')[1]})"
        for m, deps in graph.items()
        for d in deps
        if _layer(d) > _layer(m)
    )


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components of more than one module."""
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
        for w in graph.get(v, ()):
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

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return cycles


GRAPH = import_graph()


def test_every_package_has_a_layer() -> None:
    assert not unplaced(GRAPH), f"packages with no place in LAYERS: {unplaced(GRAPH)}"


def test_dependencies_run_one_way() -> None:
    bad = upward_imports(GRAPH)
    assert not bad, "upward imports:\n" + "\n".join(bad)


def test_no_import_cycles() -> None:
    cycles = import_cycles(GRAPH)
    assert not cycles, f"import cycles: {cycles}"


@pytest.fixture
def tree_copy(tmp_path: Path) -> Path:
    """A copy of the package's source tree to plant bad imports in."""
    dst = tmp_path / "odorloc"
    shutil.copytree(ROOT, dst, ignore=shutil.ignore_patterns("__pycache__", "*.so"))
    return dst


def _plant(tree: Path, module: str, text: str) -> None:
    f = tree.joinpath(*module.split(".")[1:]).with_suffix(".py")
    f.write_text(f.read_text(encoding="utf-8") + "\n" + text + "\n", encoding="utf-8")


def test_the_checkers_catch_what_is_planted_in_a_copy_of_the_tree(tree_copy: Path) -> None:
    """One upward import, one cycle and one package without a layer planted in a copy of the
    source tree are each reported, and nothing else is (a type-only upward import planted too
    is not a dependency)."""
    _plant(tree_copy, "odorloc.core.seeds", "from odorloc.searchers.base import Searcher")
    _plant(
        tree_copy,
        "odorloc.geometry.vectors",
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n"
        "    from odorloc.engine import episode",
    )
    _plant(tree_copy, "odorloc.engine.recorder", "import odorloc.engine.episode")
    (tree_copy / "newpkg").mkdir()
    (tree_copy / "newpkg" / "__init__.py").write_text("", encoding="utf-8")
    graph = import_graph(tree_copy)
    assert upward_imports(graph) == [
        "odorloc.core.seeds (core) imports odorloc.searchers.base (searchers)"
    ]
    cycles = import_cycles(graph)
    assert len(cycles) == 1 and {"odorloc.engine.recorder", "odorloc.engine.episode"} <= set(
        cycles[0]
    )
    assert unplaced(graph) == ["odorloc.newpkg"]


def _documented_layers(text: str) -> list[str]:
    """The packages of ARCHITECTURE.md's layer table, row by row and left to right."""
    out: list[str] = []
    in_table = False
    for line in text.splitlines():
        if line.startswith("| layer | package"):
            in_table = True
            continue
        if in_table:
            if not line.startswith("|"):
                break
            cells = [c.strip() for c in line.strip("|").split("|")]
            if set(cells[0]) <= {"-"}:
                continue
            out += [p.strip("`/ ") for p in cells[1].split(",")]
    return [p.replace("papers/<paper>", "papers") for p in out]


def test_architecture_md_states_the_same_layer_order() -> None:
    text = (ROOT.parents[1] / "ARCHITECTURE.md").read_text(encoding="utf-8")
    assert _documented_layers(text) == LAYERS


def test_readme_layer_chain_agrees_when_there_is_one() -> None:
    """A chain ``core -> geometry -> ...`` in the README lists layers in this order (it may
    leave some out; a package written ``a/b`` shares a step, in this order too)."""
    readme = (ROOT.parents[1] / "README.md").read_text(encoding="utf-8")
    for chain in re.findall(r"`(core ->[^`]*)`", " ".join(readme.split())):
        steps = [p.strip() for s in chain.split("->") for p in s.split("/") if p.strip()]
        assert [p for p in steps if p not in LAYERS] == [], chain
        idx = [LAYERS.index(p) for p in steps]
        assert idx == sorted(idx), f"README's chain is out of order: {chain}"


@pytest.mark.parametrize("family", ["wind", "plume", "searcher", "resampler", "model"])
def test_components_are_found_without_an_import_list(family: str) -> None:
    """Every module of the component packages registers itself by being discovered."""
    from odorloc.core import registry

    assert registry.names(family)
