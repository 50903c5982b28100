"""Rows cut into stretches (a no-spray zone across a row, a fence corner): the stretches of one row line up
across the block, and the passes must dose each stretch and nothing in the gaps between them (ENU m).

* :func:`row_lines`: stretches grouped into lines (across positions within :data:`SAME_LINE_M`, no overlap along
  the rows); the pass layout sees one row per line;
* :func:`line_spans`: where along the rows a line has canopy (its stretches' along intervals);
* :func:`cut_path`: a pass path kept over along-row spans only, each piece with whether its ends are the line's
  outer ends (run on past those, :func:`vinecli.rows.plan`; never into a gap).
"""

from __future__ import annotations

from collections.abc import Sequence

from vinecli.rows.detect import Polyline

__all__ = ["SAME_LINE_M", "cut_path", "line_spans", "merge_spans", "row_lines"]

#: stretches whose across positions differ by less than this are one row line (cut geometry: ~1e-4 m)
SAME_LINE_M = 0.05

Span = tuple[float, float]


def _along(p: tuple[float, float], u: tuple[float, float]) -> float:
    return p[0] * u[0] + p[1] * u[1]


def _span(path: Sequence[tuple[float, float]], u: tuple[float, float]) -> Span:
    t = [_along(p, u) for p in path]
    return (min(t), max(t))


def row_lines(across: Sequence[float], paths: Sequence[Polyline], u: tuple[float, float]) -> list[list[int]]:
    """Indices of ``paths`` grouped into row lines, the lines ordered across, each line's stretches along ``u``.
    Stretches that overlap along the rows (a row listed twice) are separate lines."""
    lines: list[list[int]] = []
    for i in sorted(range(len(paths)), key=lambda j: across[j]):
        a0, a1 = _span(paths[i], u)
        if lines and abs(across[i] - across[lines[-1][0]]) < SAME_LINE_M and all(
                min(a1, _span(paths[j], u)[1]) - max(a0, _span(paths[j], u)[0]) < SAME_LINE_M for j in lines[-1]):
            lines[-1].append(i)
        else:
            lines.append([i])
    for ln in lines:
        ln.sort(key=lambda j: _span(paths[j], u)[0])
    return lines


def line_spans(line: Sequence[int], paths: Sequence[Polyline], u: tuple[float, float]) -> list[Span]:
    """Along-row intervals (m) of a line's stretches."""
    return merge_spans([_span(paths[j], u) for j in line])


def merge_spans(spans: Sequence[Span]) -> list[Span]:
    """Union of intervals, sorted."""
    out: list[list[float]] = []
    for a, b in sorted(spans):
        if out and a <= out[-1][1]:
            out[-1][1] = max(out[-1][1], b)
        else:
            out.append([a, b])
    return [(a, b) for a, b in out]


def cut_path(path: Polyline, spans: Sequence[Span], u: tuple[float, float]) -> list[tuple[Polyline, bool, bool]]:
    """``path`` kept where its along position lies in ``spans``: (piece, start is an outer end, end is an outer end)
    per span it crosses, in the path's direction; the outer ends are the first and last span's outer bounds."""
    lo, hi = spans[0][0], spans[-1][1]
    forward = _along(path[-1], u) >= _along(path[0], u)
    out: list[tuple[Polyline, bool, bool]] = []
    for a, b in (spans if forward else spans[::-1]):
        piece: Polyline = []
        for p, q in zip(path[:-1], path[1:], strict=True):
            tp, tq = _along(p, u), _along(q, u)
            for t in sorted({tp, tq, a, b}, reverse=not forward):
                if min(tp, tq) - 1e-9 <= t <= max(tp, tq) + 1e-9 and a - 1e-9 <= t <= b + 1e-9:
                    f = 0.0 if tq == tp else (t - tp) / (tq - tp)
                    pt = (p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1]))
                    if not piece or (abs(pt[0] - piece[-1][0]) > 1e-9 or abs(pt[1] - piece[-1][1]) > 1e-9):
                        piece.append(pt)
        if len(piece) >= 2:
            first_outer = (a <= lo + 1e-9) if forward else (b >= hi - 1e-9)
            last_outer = (b >= hi - 1e-9) if forward else (a <= lo + 1e-9)
            out.append((piece, first_outer, last_outer))
    return out
