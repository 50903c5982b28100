"""The dependency rule (docs/architecture.md): every import of a vinecli module - at the top of a
file or inside a function - goes to the same layer or one below, and no modules import each other
in a circle. Walked with ``ast`` over the package source, so a new upward edge fails here."""

from __future__ import annotations

import ast
from pathlib import Path

from tests.repo_paths import REPO

#: the layers, ground floor first; a unit is a top-level module or a package of vinecli
LAYERS: list[set[str]] = [
    {"errors", "frames", "geo", "names", "outputs", "types"},
    {"specs"},
    {"physics", "control", "terrain", "vehicle", "mavlink"},
    {"rows"},
    {"autopilot"},
    {"world"},
    {"sim"},
    {"missions"},
    {"runs"},
    {"batch", "report"},
    {"cli", "__main__", "__init__"},
]
LAYER_OF = {unit: i for i, units in enumerate(LAYERS) for unit in units}
PKG = REPO / "vinecli"


def _module_name(path: Path) -> str:
    parts = path.relative_to(REPO).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, module: str, modules: set[str]) -> set[str]:
    """The vinecli modules ``path`` imports anywhere in it (absolute and relative imports).
    ``from vinecli.x import y`` depends on module ``vinecli.x.y`` when that is a module, else on ``vinecli.x``."""
    found: set[str] = set()
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{anchor}.{base}" if base else anchor
            found.update(f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names)
    return {m for m in found if m in modules and m != module}


def _graph() -> dict[str, set[str]]:
    files = {_module_name(p): p for p in sorted(PKG.rglob("*.py"))}
    return {mod: _imports(path, mod, set(files)) for mod, path in files.items()}


def _unit(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_unit_has_a_layer() -> None:
    units = {_unit(m) for m in _graph()}
    assert units <= set(LAYER_OF), f"modules with no layer in docs/architecture.md: {sorted(units - set(LAYER_OF))}"


def test_no_import_goes_up_a_layer() -> None:
    graph = _graph()
    upward = sorted(
        f"{src} (layer {LAYER_OF[_unit(src)]}) -> {dst} (layer {LAYER_OF[_unit(dst)]})"
        for src, dsts in graph.items() for dst in dsts
        if _unit(dst) != "__init__" and LAYER_OF[_unit(dst)] > LAYER_OF[_unit(src)]
    )
    assert not upward, "upward imports:\n" + "\n".join(upward)


def test_no_import_circles() -> None:
    graph = _graph()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []
    counter = 0

    def visit(v: str) -> None:  # Tarjan's strongly connected components
        nonlocal counter
        index[v] = low[v] = counter
        counter += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert not circles, "modules importing each other in a circle: " + "; ".join(" <-> ".join(c) for c in circles)


def test_the_rule_catches_an_upward_import(tmp_path: Path) -> None:
    """The walker sees a lazy import inside a function (how upward edges hide)."""
    f = tmp_path / "m.py"
    f.write_text("def f():\n    from vinecli.cli import app\n    from ..report import build\n")
    modules = {"vinecli.cli", "vinecli.cli.app", "vinecli.report", "vinecli.report.build", "vinecli.physics"}
    assert _imports(f, "vinecli.physics.m", modules) == {"vinecli.cli.app", "vinecli.report.build"}
