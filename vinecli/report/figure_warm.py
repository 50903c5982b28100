"""Imported by the report's process (or its fork server, off Linux) with :data:`vinecli.report.render.PRELOAD`
before it forks the processes that draw the PNG figures: draws one small figure with what those figures use (a
hillshade image, labelled contours, a line collection on a colour bar, markers, a legend, monospace text, a
256-colour PNG), so that matplotlib's lazily loaded modules, fonts and glyph caches are loaded once, before the
fork, and every worker starts warm (the first
figure of a cold process costs about 0.5 s more than the next). Importing it anywhere else only costs that time."""

from __future__ import annotations

import numpy as np

from vinecli.report.figure_base import new_figure, png_bytes


def warm_up() -> int:
    """Draw the small figure; its PNG's size in bytes."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import LightSource

    fig, axes = new_figure("fig16", 1, 1, size=(3.0, 2.0))
    ax = axes[0, 0]
    x = np.linspace(0.0, 1.0, 24)
    z = np.add.outer(np.sin(3 * x), np.cos(2 * x))
    ax.imshow(LightSource(315, 45).hillshade(z, vert_exag=3.0), cmap="gray", origin="lower", extent=(0, 1, 0, 1))
    ax.clabel(ax.contour(x, x, z, levels=4, colors="k", linewidths=0.5), fontsize=6, fmt="%.1f m")
    lc = LineCollection(np.stack([np.column_stack([x[:-1], x[:-1]]), np.column_stack([x[1:], x[1:]])], axis=1),
                        cmap="plasma")
    lc.set_array(x[:-1])
    ax.add_collection(lc)
    fig.colorbar(lc, ax=ax, label="m")
    ax.plot([0.2], [0.5], marker="X", ls="", label="marker")
    ax.barh([0.3], [0.4], label="bar")
    ax.set_xscale("log")
    ax.legend(fontsize=7)
    fig.text(0.01, 0.01, "warm", family="monospace", fontsize=8)
    ax.set_title("warm", fontsize=9)
    return len(png_bytes(fig, colour_scale=True))


WARM_PNG_BYTES = warm_up()
