"""The dependency rule (docs/architecture.md): every import of a vinecli module - at the top of a
file or inside a function - goes to the same layer or one below, and no modules, nor packages, import each
other in a circle. A private name (leading underscore) stays inside its unit: other units import public
names only. A module name repeats only in the families that say why (:data:`NAME_FAMILIES`). Walked with
``ast`` over the package source, so a new upward edge, circle or private import fails here."""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.repo_paths import REPO

#: the layers, ground floor first; a unit is a top-level module or a package of vinecli
LAYERS: list[set[str]] = [
    {"constants", "errors", "frames", "geo", "geometry", "inputs", "lifeline", "locks", "names", "native", "output_guard",
     "outputs", "scratch", "spray_defaults", "stop_signals", "types"},
    {"specs"},
    {"flight", "spray", "control", "terrain", "vehicle", "mavlink", "flightlog"},
    {"rows", "phase_items", "identify", "gis"},
    {"autopilot"},
    {"sitl"},
    {"world"},
    {"sim"},
    {"missions"},
    {"runs"},
    {"report"},
    {"batch"},
    {"cli", "__main__", "__init__"},
]
LAYER_OF = {unit: i for i, units in enumerate(LAYERS) for unit in units}
PKG = REPO / "vinecli"


#: the syntax trees of the texts this module's tests parsed (several rules read every file of vinecli/: each parses
#: it once), kept while the module runs; the trees are only read
_TREES: dict[str, ast.Module] = {}


def _parse(text: str, name: str = "<unknown>") -> ast.Module:
    """``ast.parse(text, name)``, once per text while this module's tests run."""
    tree = _TREES.get(text)
    if tree is None:
        tree = _TREES[text] = ast.parse(text, name)
    return tree


@pytest.fixture(scope="module", autouse=True)
def _trees_forgotten_after_the_module() -> Iterator[None]:
    yield
    _TREES.clear()


def _module_name(path: Path) -> str:
    parts = path.relative_to(REPO).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(path: Path, module: str, modules: set[str]) -> set[str]:
    """The vinecli modules ``path`` imports anywhere in it (absolute and relative imports).
    ``from vinecli.x import y`` depends on module ``vinecli.x.y`` when that is a module, else on ``vinecli.x``."""
    found: set[str] = set()
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    for node in ast.walk(_parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{anchor}.{base}" if base else anchor
            found.update(f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names)
    return {m for m in found if m in modules and m != module}


def import_graph() -> dict[str, set[str]]:
    files = {_module_name(p): p for p in sorted(PKG.rglob("*.py"))}
    return {mod: _imports(path, mod, set(files)) for mod, path in files.items()}


def unit_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_unit_has_a_layer() -> None:
    units = {unit_of(m) for m in import_graph()}
    assert units <= set(LAYER_OF), f"modules with no layer in docs/architecture.md: {sorted(units - set(LAYER_OF))}"


def test_no_import_goes_up_a_layer() -> None:
    graph = import_graph()
    upward = sorted(
        f"{src} (layer {LAYER_OF[unit_of(src)]}) -> {dst} (layer {LAYER_OF[unit_of(dst)]})"
        for src, dsts in graph.items() for dst in dsts
        if unit_of(dst) != "__init__" and LAYER_OF[unit_of(dst)] > LAYER_OF[unit_of(src)]
    )
    assert not upward, "upward imports:\n" + "\n".join(upward)


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (Tarjan): the nodes importing each other in a circle."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []
    counter = 0

    def visit(v: str) -> None:
        nonlocal counter
        index[v] = low[v] = counter
        counter += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
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
    return circles


def test_no_import_circles() -> None:
    circles = _circles(import_graph())
    assert not circles, "modules importing each other in a circle: " + "; ".join(" <-> ".join(c) for c in circles)


def _package(module: str, packages: set[str]) -> str:
    """The package a module belongs to (itself for a package); a module of vinecli's top level is a unit of its own."""
    if module in packages:
        return module
    parent = module.rsplit(".", 1)[0]
    return module if parent == "vinecli" else parent


def _package_graph(graph: dict[str, set[str]], packages: set[str]) -> dict[str, set[str]]:
    """Imports between packages; a package and the packages inside it are one room (their edges are not counted)."""
    out: dict[str, set[str]] = {}
    for src, dsts in graph.items():
        a = _package(src, packages)
        for dst in dsts:
            b = _package(dst, packages)
            if a != b and not b.startswith(a + ".") and not a.startswith(b + "."):
                out.setdefault(a, set()).add(b)
    return out


def test_no_package_circles() -> None:
    """Two packages (batch and report, sitl/px4 and sitl/ardupilot, ...) never import each other, directly or
    through others: a package's modules may depend on one another, packages only one way."""
    packages = {_module_name(p.parent / "__init__.py") for p in PKG.rglob("__init__.py")}
    circles = _circles(_package_graph(import_graph(), packages))
    assert not circles, "packages importing each other in a circle: " + "; ".join(" <-> ".join(c) for c in circles)


def test_the_rule_catches_a_package_circle() -> None:
    graph = {"vinecli.batch.run": {"vinecli.report.plots"}, "vinecli.report.loader": {"vinecli.batch.run"},
             "vinecli.report.plots": set(), "vinecli.sitl.options": {"vinecli.sitl.px4.backend"},
             "vinecli.sitl.px4.backend": {"vinecli.sitl.process"}, "vinecli.sitl.process": set()}
    packages = {"vinecli.batch", "vinecli.report", "vinecli.sitl", "vinecli.sitl.px4"}
    assert _circles(_package_graph(graph, packages)) == [["vinecli.batch", "vinecli.report"]]


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
    tree = _parse(path.read_text(), str(path))
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
        if unit_of(name) != unit_of(src)
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


#: a function takes at most this many parameters (``self``/``cls`` not counted, ``*args`` and ``**kwargs`` one each):
#: more travel in one named object, unless a comment at the def says why (:data:`WIDE_REASON`)
MAX_PARAMETERS = 8
#: the comment that says why a function takes more, on the lines just above its def (or in its signature)
WIDE_REASON = re.compile(r"#\s*parameters:\s*\S.{9,}")
#: names of results and records (a run's, a firmware's, a deposition's): never annotated ``Any``
RESULTISH = re.compile(r"^(result|record|dep|deposition)$|_(result|record)$|^(result|record)_")


def _parameter_count(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    a = fn.args
    names = [x.arg for x in a.posonlyargs + a.args]
    if names and names[0] in ("self", "cls"):
        names = names[1:]
    return len(names) + len(a.kwonlyargs) + (a.vararg is not None) + (a.kwarg is not None)


def _wide_without_reason(text: str) -> list[tuple[int, str, int]]:
    """(line, function, parameters) of every function of ``text`` over :data:`MAX_PARAMETERS` whose def has no
    :data:`WIDE_REASON` comment: in the comment block right above it (above its decorators) or in its signature."""
    lines = text.splitlines()
    out = []
    for node in ast.walk(_parse(text)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and _parameter_count(node) > MAX_PARAMETERS:
            top = min([node.lineno, *(d.lineno for d in node.decorator_list)]) - 1  # 0-based index of the first line
            above = top - 1
            while above >= 0 and lines[above].lstrip().startswith("#"):
                above -= 1
            comments = lines[above + 1:top] + lines[node.lineno - 1:node.body[0].lineno - 1]
            if not any(WIDE_REASON.search(line) for line in comments):
                out.append((node.lineno, node.name, _parameter_count(node)))
    return out


def test_functions_take_few_parameters_or_say_why() -> None:
    wide = [f"{path.relative_to(REPO)}:{line} {name} ({n} parameters)"
            for path in sorted(PKG.rglob("*.py")) for line, name, n in _wide_without_reason(path.read_text())]
    assert not wide, (f"functions with more than {MAX_PARAMETERS} parameters: pass a named object, or say why at the "
                      "def ('# parameters: ...'):\n" + "\n".join(wide))


def test_the_parameter_rule_reads_the_reason() -> None:
    nine = "a, b, c, d, e, f, g, h, i"
    src = (f"def bare({nine}): pass\n"
           f"# parameters: the nine inputs of a published formula\n@decorated\ndef said({nine}): pass\n"
           f"def inline(\n    {nine},  # parameters: Typer reads one option per parameter\n): pass\n"
           f"# parameters:\ndef empty({nine}): pass\n"
           f"class C:\n    def method(self, a, b, c, d, e, f, g, h): pass\n    def more(self, *, {nine}): pass\n")
    assert [name for _, name, _ in _wide_without_reason(src)] == ["bare", "empty", "more"]


def _any_annotated(text: str) -> list[tuple[int, str]]:
    """(line, name) of every parameter, field or attribute named like a result or record (:data:`RESULTISH`)
    annotated ``Any`` (alone or with None)."""
    def is_any(ann: ast.expr | None) -> bool:
        if ann is None:
            return False
        words = ast.unparse(ann).replace("typing.", "").replace("Optional[", "").replace("]", "").replace(" ", "")
        return "Any" in words.split("|") or words.strip("'\"") == "Any"

    out = []
    for node in ast.walk(_parse(text)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            a = node.args
            out += [(x.lineno, x.arg) for x in a.posonlyargs + a.args + a.kwonlyargs
                    if RESULTISH.search(x.arg) and is_any(x.annotation)]
        elif isinstance(node, ast.AnnAssign) and is_any(node.annotation):
            target = node.target
            name = target.id if isinstance(target, ast.Name) else target.attr if isinstance(target, ast.Attribute) else ""
            if RESULTISH.search(name):
                out.append((node.lineno, name))
    return out


def test_no_result_or_record_is_any() -> None:
    untyped = [f"{path.relative_to(REPO)}:{line} {name}"
               for path in sorted(PKG.rglob("*.py")) for line, name in _any_annotated(path.read_text())]
    assert not untyped, "results and records annotated Any (give their type):\n" + "\n".join(untyped)


def test_the_any_rule_sees_parameters_fields_and_attributes() -> None:
    src = ("from typing import Any, Optional\n"
           "def f(result: Any, run_record: Any | None, record: 'Any', summary: Any, dep: dict[str, Any]): pass\n"
           "class R:\n    deposition: Optional[Any] = None\n    result: int = 0\n"
           "    def __init__(self):\n        self.firmware_record: Any = None\n")
    assert [name for _, name in _any_annotated(src)] == ["result", "run_record", "record", "deposition",
                                                          "firmware_record"]


#: small files with one job, short functions: limits for every file and function of vinecli/
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
        for node in ast.walk(_parse(text, rel)):
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


#: where a module's file name may repeat, and why (each package's docstring says it too): a name that says which
#: part of the product the module serves, the same in every package where it occurs
NAME_FAMILIES: dict[str, str] = {
    "vinecli/cli/": "the command line: one module per command group (vinecli terrain, plan, run, ...) and its options",
    "vinecli/specs/": "a spec is named after the part it specifies (vehicle, wind, mission, sprayer, canopy)",
    "vinecli/missions/metrics/": "metric families, named after what they measure (takeoff, wind, job)",
    "defaults.py": "a package's defaults, light to import for the command line's help (terrain, identify)",
    "read.py": "a file-format package's reader (gis, flightlog)",
}
#: inside it a name may repeat once per firmware (px4/, ardupilot/) and for their shared part: the same role
PER_FIRMWARE = "vinecli/sitl/"


def _in_family(path: str) -> bool:
    return any(path.startswith(f) or path.endswith("/" + f) for f in NAME_FAMILIES)


def test_every_package_says_what_lives_there_and_what_it_may_import() -> None:
    """Each package's ``__init__.py`` has a docstring, and it says what the package may import."""
    silent = sorted(p.relative_to(REPO).as_posix() for p in PKG.rglob("__init__.py")
                    if "may import" not in " ".join((ast.get_docstring(_parse(p.read_text(), str(p))) or "").lower().split()))
    assert not silent, f"packages whose __init__ docstring does not say what they may import: {silent}"


def test_module_names_repeat_only_for_a_reason() -> None:
    """A file name several modules use (``__init__.py`` aside) is allowed when all of them but one sit in a
    :data:`NAME_FAMILIES`, or the rest all in :data:`PER_FIRMWARE`: anything else is two modules named alike for no
    reason (``mission.py`` in runs/ and in sitl/px4/), which a reader has to tell apart."""
    by_name: dict[str, list[str]] = {}
    for path in sorted(PKG.rglob("*.py")):
        if path.name != "__init__.py":
            by_name.setdefault(path.name, []).append(path.relative_to(REPO).as_posix())
    alike = {}
    for name, paths in by_name.items():
        rest = [p for p in paths if not _in_family(p)]
        if len(rest) > 1 and not all(p.startswith(PER_FIRMWARE) for p in rest):
            alike[name] = paths
    assert not alike, f"modules named alike without a reason (rename one, or say why in NAME_FAMILIES): {alike}"
