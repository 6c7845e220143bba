"""House style for figures a naval architect would put in a report, and an atomic saver.

Figures are laid out by fixed margins in inches (:func:`new_figure`), not by a layout engine:
matplotlib's constrained layout draws every figure twice (once to measure, once to render),
which was half of the time of ``flexlift run``. Each save is one draw at ``savefig.dpi``.
"""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; nothing in flexlift opens a window

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import LogLocator, NullLocator  # noqa: E402

STYLE = {
    "figure.figsize": (8.0, 4.5),
    "figure.dpi": 100,
    "savefig.dpi": 100,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "font.size": 9.5,
    "axes.titlesize": 10.5,
    "legend.fontsize": 8.5,
    "legend.frameon": False,
    # titles at a fixed height over the axes: matplotlib otherwise lays out every y axis's
    # ticks once more per title, before drawing, to lift it over top tick labels (a figure
    # with labels or an offset text up there pads its title itself)
    "axes.titley": 1.0,
}

#: default margins [in]: left, right, bottom, top, and the gaps between rows and columns
MARGINS = {"left": 0.8, "right": 0.2, "bottom": 0.55, "top": 0.4, "hgap": 0.5, "wgap": 0.8}
#: extra room above the axes for a figure title (suptitle) [in]
SUPTITLE = 0.3


def new_figure(nrows: int = 1, ncols: int = 1, margins: dict | None = None, **kw):
    """A figure and axes in the house style. ``margins`` overrides entries of
    :data:`MARGINS` [in]; they are applied when the figure is saved (a title added with
    ``suptitle`` gets :data:`SUPTITLE` more at the top)."""
    with plt.rc_context(STYLE):
        fig, ax = plt.subplots(nrows, ncols, **kw)
    fig._flexlift_margins = {**MARGINS, **(margins or {}), "rows": nrows, "cols": ncols}
    return fig, ax


def apply_margins(fig) -> None:
    """Place the subplots of a :func:`new_figure` by its margins (no effect on others)."""
    m = getattr(fig, "_flexlift_margins", None)
    if m is None:
        return
    W, H = fig.get_size_inches()
    top = m["top"] + (SUPTITLE if fig._suptitle is not None else 0.0)
    axw = (W - m["left"] - m["right"] - (m["cols"] - 1) * m["wgap"]) / m["cols"]
    axh = (H - m["bottom"] - top - (m["rows"] - 1) * m["hgap"]) / m["rows"]
    fig.subplots_adjust(left=m["left"] / W, right=1 - m["right"] / W, bottom=m["bottom"] / H,
                        top=1 - top / H, wspace=m["wgap"] / max(axw, 0.1),
                        hspace=m["hgap"] / max(axh, 0.1))


def lean_log_axes(ax, max_decades: float = 4.0) -> None:
    """On a log axis spanning more than ``max_decades``: no minor ticks and at most seven
    labelled decades (a tick is two lines and a text to lay out: they cost time, and so many
    add nothing to read)."""
    for axis, scale, lim in ((ax.xaxis, ax.get_xscale(), ax.get_xlim()),
                             (ax.yaxis, ax.get_yscale(), ax.get_ylim())):
        if scale != "log" or min(lim) <= 0:
            continue
        if abs(np.log10(lim[1] / lim[0])) > max_decades:
            axis.set_minor_locator(NullLocator())
            axis.set_major_locator(LogLocator(numticks=7))


def save(fig, path: str | os.PathLike) -> Path:
    """Save ``fig`` as PNG atomically (one draw) and close it; returns the path."""
    from flexlift.output.files import atomic_file

    path = Path(path)
    try:
        apply_margins(fig)
        for ax in fig.axes:
            lean_log_axes(ax)
        with atomic_file(path, suffix=".png") as tmp, plt.rc_context(STYLE):
            fig.savefig(tmp, format="png")
    finally:
        plt.close(fig)
    return path
