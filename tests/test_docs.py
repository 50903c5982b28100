"""The docs match the code: every document a comment or docstring cites exists in the repository (no notes kept
elsewhere), no comment, docstring or doc names an issue number (it says the reason; history is git's), and
every module, name and file the docs name (``vinecli.x.y``, ``vinecli/x/y.py``) exists."""

from __future__ import annotations

import ast
import functools
import re
import subprocess
from pathlib import Path

from tests.repo_paths import REPO

#: files vinecli writes, named in code and docs like documents
OUTPUT_NAMES = {"summary.md"}
#: build products named in the docs (absent from a fresh clone until built)
BUILT = {"vinecli/native.json"}
MD = re.compile(r"(?<![\w/.-])((?:\.\./)*[\w./-]*[\w-]+\.md)\b")
ISSUE = re.compile(r"\b[Ii]ssues? #?\d+")
DOTTED = re.compile(r"(?<![\w.])vinecli(?:\.\w+)+(?![\w/])")
PATH = re.compile(r"(?<![\w./-])((?:vinecli|tests|scripts|benchmarks|docs|pipelines|worlds|vehicles)/[\w./-]*\w)(?![*\w])")


def _files(*suffixes: str) -> list[Path]:
    out = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=REPO, capture_output=True, text=True,
                         check=True).stdout.split()
    return [REPO / f for f in out if f.endswith(suffixes) and not f.startswith("tests/data/") and (REPO / f).is_file()]


def _code() -> list[Path]:
    """The Python files of the repository, this one aside (its examples are what the checks look for)."""
    return [p for p in _files(".py") if (p.relative_to(REPO).parts[0] in ("vinecli", "tests", "scripts", "benchmarks")
                                         or p.name == "hatch_build.py") and p != Path(__file__).resolve()]


def _docs() -> list[Path]:
    return sorted((REPO / "docs").glob("*.md")) + [REPO / "README.md", REPO / "CONTRIBUTING.md"]


def test_every_document_the_code_cites_exists() -> None:
    missing = sorted(
        f"{p.relative_to(REPO)}: {m.group(1)}"
        for p in _code() for m in MD.finditer(p.read_text())
        if m.group(1) not in OUTPUT_NAMES and not (
            (REPO / m.group(1)).is_file() if "/" in m.group(1)
            else (REPO / m.group(1)).is_file() or (REPO / "docs" / m.group(1)).is_file()))
    assert not missing, "documents cited but not in the repository (write them in docs/ or cite one there):\n" + \
        "\n".join(missing)


def test_nothing_names_an_issue_number() -> None:
    """An issue number means nothing to a reader of the code or the docs: say the reason instead (BENCHMARKS.md,
    a record of measurements over time, may date them)."""
    found = sorted(f"{p.relative_to(REPO)}:{i}: {line.strip()[:100]}"
                   for p in _code() + _docs() for i, line in enumerate(p.read_text().splitlines(), 1)
                   if ISSUE.search(line))
    assert not found, "issue numbers:\n" + "\n".join(found)


@functools.cache
def _top_names(src: Path) -> set[str]:
    """The names a module defines or imports at its top level (and under ``if TYPE_CHECKING``), and its ``__all__``."""
    names: set[str] = set()
    tree = ast.parse(src.read_text())
    for node in [*tree.body, *(s for n in tree.body if isinstance(n, ast.If) for s in n.body)]:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.Assign):
            names |= {t.id for t in node.targets if isinstance(t, ast.Name)}
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            names.add(node.target.id)
        elif isinstance(node, ast.Import | ast.ImportFrom):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
    return names


def _exists(dotted: str) -> bool:
    """``vinecli.a.b[.name]``: the longest module prefix exists and defines the name after it (attributes of that
    name are not followed)."""
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        base = REPO.joinpath(*parts[:i])
        src = base.with_suffix(".py") if base.with_suffix(".py").is_file() else base / "__init__.py"
        if src.is_file():
            return i == len(parts) or parts[i] in _top_names(src)
    return False


def test_the_docs_name_modules_and_files_that_exist() -> None:
    wrong = []
    for doc in _docs():
        text = doc.read_text()
        wrong += [f"{doc.name}: {m.group(0)}" for m in DOTTED.finditer(text)
                  if not m.group(0).endswith(".parm") and not _exists(m.group(0))]
        wrong += [f"{doc.name}: {m.group(1)}" for m in PATH.finditer(text)
                  if not any(c in m.group(1) for c in "{<") and m.group(1) not in BUILT
                  and not (REPO / m.group(1)).exists()]
    assert not wrong, "the docs name modules, names or files that do not exist:\n" + "\n".join(sorted(set(wrong)))


def test_the_checks_catch_what_they_look_for() -> None:
    assert _exists("vinecli.flight.motor.MotorBank") and _exists("vinecli.runs.batch_json")
    assert not _exists("vinecli.physics.motor") and not _exists("vinecli.flight.motor.NoSuchThing")
    assert ISSUE.search("(issue 20 item 3)") and not ISSUE.search("isl-org/Open3D#6272")
    assert [m.group(1) for m in MD.finditer("see design.md §3 and docs/terrain.md §4")] == ["design.md",
                                                                                         "docs/terrain.md"]
