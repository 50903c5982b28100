"""The dependency rule (docs/architecture.md): every import of a vinecli module - at the top of a
file or inside a function - goes to the same layer or one below, and no modules import each other
in a circle. A private name (leading underscore) stays inside its unit: other units import public
names only. Walked with ``ast`` over the package source, so a new upward edge or private import fails here."""

from __future__ import annotations

import ast
from pathlib import Path

from tests.repo_paths import REPO

#: the layers, ground floor first; a unit is a top-level module or a package of vinecli
LAYERS: list[set[str]] = [
    {"constants", "errors", "frames", "geo", "inputs", "lifeline", "locks", "names", "native", "output_guard", "outputs",
     "spray_defaults", "types"},
    {"specs"},
    {"flight", "spray", "control", "terrain", "vehicle", "mavlink", "flightlog"},
    {"rows", "phase_items", "identify", "gis"},
    {"autopilot"},
    {"sitl"},
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


def _is_private(name: str) -> bool:
    """A leading underscore, not a dunder (``__version__`` is public)."""
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _private_uses(path: Path, module: str, modules: set[str]) -> list[tuple[int, str]]:
    """(line, ``vinecli.x._name``) for every private name ``path`` takes from a vinecli module: imported with
    ``from vinecli.x import _name``, a private module in an import path (``vinecli.x._mod``), or read as an
    attribute of an imported vinecli module (``import vinecli.x as m; m._name``)."""
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text(), str(path))
    found: list[tuple[int, str]] = []
    aliases: dict[str, str] = {}  # local name -> vinecli module it is bound to
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("vinecli."):
                    found += [(node.lineno, a.name) for part in a.name.split(".") if _is_private(part)][:1]
                    if a.asname:
                        aliases[a.asname] = a.name
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{anchor}.{base}" if base else anchor
            if base != "vinecli" and not base.startswith("vinecli."):
                continue
            if any(_is_private(part) for part in base.split(".")):
                found.append((node.lineno, base))
            for a in node.names:
                full = f"{base}.{a.name}"
                if _is_private(a.name):
                    found.append((node.lineno, full))
                elif full in modules:
                    aliases[a.asname or a.name] = full
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in aliases
                and _is_private(node.attr)):
            found.append((node.lineno, f"{aliases[node.value.id]}.{node.attr}"))
    return found


def test_no_private_name_crosses_a_unit() -> None:
    """A name with a leading underscore is private to its unit (a top-level module or package of vinecli):
    modules of the same package may share helpers, every other unit uses public names only."""
    files = {_module_name(p): p for p in sorted(PKG.rglob("*.py"))}
    crossing = sorted(
        f"{src}:{line} uses {name}"
        for src, path in files.items() for line, name in _private_uses(path, src, set(files))
        if _unit(name) != _unit(src)
    )
    assert not crossing, "private names used outside their unit:\n" + "\n".join(crossing)


def test_the_rule_catches_a_private_import(tmp_path: Path) -> None:
    """Each way of reaching a private name is seen (top level, inside a function, relative, via a module alias)."""
    f = tmp_path / "m.py"
    f.write_text("from vinecli.outputs import _jsonable, write_json\n"
                 "from vinecli import __version__, outputs\n"
                 "import vinecli.report.baseline as bl\n"
                 "def f():\n    from ..report.loader import _load_run\n    return outputs._x(bl._fmt)\n")
    modules = {"vinecli.outputs", "vinecli.report.baseline", "vinecli.report.loader", "vinecli.physics.m"}
    names = sorted(n for _, n in _private_uses(f, "vinecli.physics.m", modules))
    assert names == ["vinecli.outputs._jsonable", "vinecli.outputs._x", "vinecli.report.baseline._fmt",
                     "vinecli.report.loader._load_run"]


#: small files with one job, short functions (issue 24): limits for every file and function of vinecli/
MAX_FILE_LINES = 500
MAX_FUNCTION_LINES = 120
#: temporary exceptions, each with who removes it and when; an exception that is no longer needed fails
SIZE_EXCEPTIONS: dict[str, str] = {
}


def _sizes() -> tuple[dict[str, int], list[tuple[str, str, int]]]:
    """Lines per file (repo-relative) and (file, function, lines) of every function over the limit."""
    files: dict[str, int] = {}
    long: list[tuple[str, str, int]] = []
    for path in sorted(PKG.rglob("*.py")):
        rel = path.relative_to(REPO).as_posix()
        text = path.read_text()
        files[rel] = len(text.splitlines())
        for node in ast.walk(ast.parse(text, rel)):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                n = (node.end_lineno or node.lineno) - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long.append((rel, node.name, n))
    return files, long


def test_files_and_functions_stay_small() -> None:
    files, long = _sizes()
    big = {f: n for f, n in files.items() if n > MAX_FILE_LINES and f not in SIZE_EXCEPTIONS}
    assert not big, f"files over {MAX_FILE_LINES} lines (split them by job): {big}"
    long = [x for x in long if x[0] not in SIZE_EXCEPTIONS]
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines: {long}"
    stale = [f for f in SIZE_EXCEPTIONS if f not in files or files[f] <= MAX_FILE_LINES]
    assert not stale, f"remove these size exceptions, they are no longer needed: {stale}"
