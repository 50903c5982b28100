"""Draw the house: vinecli's packages floor by floor and the imports between them, as docs/house.svg.

    python scripts/draw_house.py            # write docs/house.svg
    python scripts/draw_house.py --check    # exit 1 when docs/house.svg is not what the code draws now

The floors are the dependency rule's (``LAYERS`` in tests/test_architecture.py); the arrows are the imports its
walker finds (every import of a vinecli module, lazy ones inside functions included), one arrow per pair of
packages. The two bottom floors (the ground floor's constants, errors, frames, ... and the specs) are imported by
nearly every package: arrows into them are left out. Plain SVG written the same way every time (no layout engine, sorted input), so it renders on GitHub and
offline and tests/test_house_picture.py can tell when the committed picture is stale.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import escape

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "docs" / "house.svg"

BOX_H = 26.0
FLOOR_H = 74.0
CHAR_W = 7.3  # 12 px monospace
GAP = 26.0
MIN_W = 130.0  # boxes at least this wide, so the arrows at one box spread out
LANE = 5.0  # arrows that pass floors run in lanes this far apart beside the boxes they pass
MARGIN_L = 70.0
MARGIN_R = 24.0
TOP = 46.0


@dataclass
class Box:
    name: str
    floor: int
    x: float = 0.0
    w: float = 0.0

    @property
    def cx(self) -> float:
        return self.x + self.w / 2


def house() -> tuple[list[list[str]], set[tuple[str, str]]]:
    """(the floors' packages, ground floor first; the imports between packages, those into the two bottom floors
    left out)."""
    sys.path.insert(0, str(REPO))
    from tests.test_architecture import LAYERS, import_graph, unit_of

    floors = [sorted(u for u in layer if u not in ("__init__", "__main__")) for layer in LAYERS]
    ground = set(LAYERS[0]) | {"__init__", "__main__"}
    everyones = ground | set(LAYERS[1])
    edges = {(unit_of(src), unit_of(dst)) for src, dsts in import_graph().items() for dst in dsts}
    return floors, {(a, b) for a, b in edges if a != b and a not in ground and b not in everyones}


def _order(floors: list[list[str]], edges: set[tuple[str, str]]) -> list[list[str]]:
    """Packages of each floor ordered so arrows cross less: a few sweeps placing each package at the mean position
    of the packages it is joined to (ties by name)."""
    order = [list(f) for f in floors]
    nbrs: dict[str, set[str]] = {}
    for a, b in edges:
        nbrs.setdefault(a, set()).add(b)
        nbrs.setdefault(b, set()).add(a)
    for _ in range(6):
        pos = {u: (i + 0.5) / len(f) for f in order for i, u in enumerate(f)}
        for f in order:
            f.sort(key=lambda u: (sum(pos[v] for v in nbrs.get(u, ())) / len(nbrs[u]) if nbrs.get(u) else pos[u], u))
    return order


def _box_w(name: str, level: int) -> float:
    return len(name) * CHAR_W + 20 if level == 0 else max(MIN_W, len(name) * CHAR_W + 20)


def _fmt(v: float) -> str:
    return f"{v:.1f}"


def draw(floors: list[list[str]], edges: set[tuple[str, str]]) -> str:
    """The SVG text of the house."""
    upper = _order(floors[1:], edges)
    ground_label = "ground floor: " + ", ".join(floors[0])
    rows = [[ground_label], *upper]
    widths = [sum(_box_w(u, level) for u in row) + GAP * (len(row) - 1) for level, row in enumerate(rows)]
    width = max(widths) + MARGIN_L + MARGIN_R
    n = len(rows)
    height = TOP + n * FLOOR_H + 58
    boxes: dict[str, Box] = {}
    parts: list[str] = []
    for level, row in enumerate(rows):
        y_band = TOP + (n - 1 - level) * FLOOR_H
        fill = "#f4f6fa" if level % 2 == 0 else "#ffffff"
        parts.append(f'<rect x="0" y="{_fmt(y_band)}" width="{_fmt(width)}" height="{_fmt(FLOOR_H)}" fill="{fill}"/>')
        parts.append(f'<text x="14" y="{_fmt(y_band + FLOOR_H / 2 + 4)}" class="floor">{level}</text>')
        x = MARGIN_L + (width - MARGIN_L - MARGIN_R - widths[level]) / 2
        for u in row:
            box = Box(u, level, x, _box_w(u, level))
            boxes[u] = box
            x += box.w + GAP
    y_box = {level: TOP + (n - 1 - level) * FLOOR_H + (FLOOR_H - BOX_H) / 2 for level in range(n)}
    # arrow ends spread along the box edges, in the order of the boxes at their other end
    starts: dict[str, list[tuple[str, str]]] = {}
    ends: dict[str, list[tuple[str, str]]] = {}
    for a, b in sorted(edges):
        starts.setdefault(a, []).append((a, b))
        ends.setdefault(b, []).append((a, b))

    def spot(box: Box, mine: list[tuple[str, str]], edge: tuple[str, str], other: int) -> float:
        ranked = sorted(mine, key=lambda e: (boxes[e[other]].cx, e[other]))
        i = ranked.index(edge)
        return box.x + box.w * (i + 1) / (len(ranked) + 1)

    # an arrow passing floors runs in a lane of its own beside the boxes of the floors it passes
    def passed(e: tuple[str, str]) -> list[Box]:
        lo, hi = boxes[e[1]].floor, boxes[e[0]].floor
        return [bx for bx in boxes.values() if lo < bx.floor < hi]

    mid = (MARGIN_L + width - MARGIN_R) / 2
    long_edges = sorted((e for e in edges if boxes[e[0]].floor - boxes[e[1]].floor > 1),
                        key=lambda e: (boxes[e[0]].floor - boxes[e[1]].floor, e))
    lanes: dict[tuple[str, str], float] = {}
    used: dict[str, int] = {"left": 0, "right": 0}
    for e in long_edges:
        side = "right" if (boxes[e[1]].cx, boxes[e[0]].cx) >= (mid, mid) else "left"
        wall = [bx for bx in passed(e) if abs(bx.cx - mid) < MIN_W]
        if side == "right":
            edge_x = max([bx.x + bx.w for bx in wall], default=mid)
            lanes[e] = edge_x + 12 + LANE * used[side]
        else:
            edge_x = min([bx.x for bx in wall], default=mid)
            lanes[e] = edge_x - 12 - LANE * used[side]
        used[side] += 1

    lines: list[str] = []
    for a, b in sorted(edges):
        ba, bb = boxes[a], boxes[b]
        x1, x2 = spot(ba, starts[a], (a, b), 1), spot(bb, ends[b], (a, b), 0)
        if ba.floor == bb.floor:  # sideways within a floor: an arc above the boxes
            y = y_box[ba.floor]
            d = f"M{_fmt(x1)},{_fmt(y)} Q{_fmt((x1 + x2) / 2)},{_fmt(y - 24)} {_fmt(x2)},{_fmt(y)}"
        elif (a, b) in lanes:
            lx = lanes[(a, b)]
            y1, y2 = y_box[ba.floor] + BOX_H, y_box[bb.floor]
            d = (f"M{_fmt(x1)},{_fmt(y1)} C{_fmt(x1)},{_fmt(y1 + 22)} {_fmt(lx)},{_fmt(y1 + 8)} {_fmt(lx)},"
                 f"{_fmt(y1 + 30)} L{_fmt(lx)},{_fmt(y2 - 30)} C{_fmt(lx)},{_fmt(y2 - 8)} {_fmt(x2)},{_fmt(y2 - 22)} "
                 f"{_fmt(x2)},{_fmt(y2)}")
        else:
            y1, y2 = y_box[ba.floor] + BOX_H, y_box[bb.floor]
            d = (f"M{_fmt(x1)},{_fmt(y1)} C{_fmt(x1)},{_fmt(y1 + 30)} {_fmt(x2)},{_fmt(y2 - 30)} "
                 f"{_fmt(x2)},{_fmt(y2)}")
        lines.append(f'<path d="{d}" class="edge"><title>{escape(a)} imports {escape(b)}</title></path>')
    for u, box in boxes.items():
        y = y_box[box.floor]
        parts_box = (f'<rect x="{_fmt(box.x)}" y="{_fmt(y)}" width="{_fmt(box.w)}" height="{_fmt(BOX_H)}" rx="5" '
                     f'class="{"ground" if box.floor == 0 else "pkg"}"/>'
                     f'<text x="{_fmt(box.cx)}" y="{_fmt(y + BOX_H / 2 + 4)}" class="name">{escape(u)}</text>')
        lines.append(parts_box)
    notes = ("An arrow: a package imports another (down, or sideways within a floor; never up, never in a circle).",
             "Floors 0 and 1 are for everyone: arrows into them are not drawn. Drawn by scripts/draw_house.py.")
    head = (f'<svg xmlns="http://www.w3.org/2000/svg" width="{_fmt(width)}" height="{_fmt(height)}" '
            f'viewBox="0 0 {_fmt(width)} {_fmt(height)}" font-family="DejaVu Sans Mono, Menlo, Consolas, monospace">\n'
            "<defs><marker id=\"arrow\" viewBox=\"0 0 8 8\" refX=\"7\" refY=\"4\" markerWidth=\"7\" "
            "markerHeight=\"7\" orient=\"auto-start-reverse\"><path d=\"M0,0 L8,4 L0,8 z\" fill=\"#5b6f91\"/>"
            "</marker>\n<style>.edge{fill:none;stroke:#5b6f91;stroke-opacity:0.5;stroke-width:1;"
            "marker-end:url(#arrow)}.pkg{fill:#dde7f7;stroke:#34507a}.ground{fill:#eeeeee;stroke:#777777}"
            ".name{font-size:12px;text-anchor:middle;fill:#15233a}.floor{font-size:13px;font-weight:bold;"
            "fill:#34507a}.title{font-size:15px;font-weight:bold;fill:#15233a}.note{font-size:11px;fill:#444444}"
            "</style></defs>\n")
    title = ('<text x="14" y="26" class="title">vinecli: packages by floor (the dependency rule) and the imports '
             'between them</text>\n')
    foot = "".join(f'<text x="14" y="{_fmt(height - 34 + 15 * i)}" class="note">{escape(s)}</text>\n'
                   for i, s in enumerate(notes))
    return head + "\n".join(parts) + "\n" + title + "\n".join(lines) + "\n" + foot + "</svg>\n"


def main() -> int:
    ap = argparse.ArgumentParser(description="Draw docs/house.svg from the code.")
    ap.add_argument("--check", action="store_true", help="exit 1 when docs/house.svg is stale")
    args = ap.parse_args()
    svg = draw(*house())
    if args.check:
        if not OUT.is_file() or OUT.read_text() != svg:
            print(f"{OUT.relative_to(REPO)} is stale: run python scripts/draw_house.py", file=sys.stderr)
            return 1
        return 0
    OUT.write_text(svg)
    print(f"wrote {OUT.relative_to(REPO)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
