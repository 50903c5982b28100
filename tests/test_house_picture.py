"""The house in docs/architecture.md (docs/house.svg) is the picture scripts/draw_house.py draws from the code now:
a new package, a package moved to another floor or a new import between packages without a new picture fails
here (run ``python scripts/draw_house.py`` and commit docs/house.svg)."""

from __future__ import annotations

import importlib.util
import re
import sys
from types import ModuleType

from tests.repo_paths import REPO


def _script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("draw_house", REPO / "scripts" / "draw_house.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # its dataclasses look their module up
    spec.loader.exec_module(mod)
    return mod


def test_the_committed_picture_is_what_the_code_draws() -> None:
    draw = _script()
    svg = draw.draw(*draw.house())
    assert (REPO / "docs" / "house.svg").read_text() == svg, "docs/house.svg is stale: run python scripts/draw_house.py"


def test_the_picture_shows_every_package_and_every_import_between_them() -> None:
    draw = _script()
    floors, edges = draw.house()
    svg = draw.draw(floors, edges)
    boxes = set(re.findall(r'class="name">([^<]+)</text>', svg))
    assert set().union(*floors[1:]) <= boxes and any(b.startswith("ground floor: constants") for b in boxes)
    drawn = set(re.findall(r"<title>(\w+) imports (\w+)</title>", svg))
    assert drawn == edges and ("batch", "report") in drawn and ("report", "batch") not in drawn
    assert ("spray", "flight") in drawn and ("flight", "spray") not in drawn
