"""House style for figures a naval architect would put in a report, and an atomic saver."""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; nothing in flexlift opens a window

import matplotlib.pyplot as plt  # noqa: E402

STYLE = {
    "figure.figsize": (8.0, 4.5),
    "figure.dpi": 110,
    "savefig.dpi": 130,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "font.size": 9.5,
    "axes.titlesize": 10.5,
    "legend.fontsize": 8.5,
    "legend.frameon": False,
}


def new_figure(nrows: int = 1, ncols: int = 1, **kw):
    """A figure and axes in the house style."""
    with plt.rc_context(STYLE):
        fig, ax = plt.subplots(nrows, ncols, layout="constrained", **kw)
    return fig, ax


def save(fig, path: str | os.PathLike) -> Path:
    """Save ``fig`` as PNG atomically and close it; returns the path."""
    from flexlift.output.files import atomic_file

    path = Path(path)
    try:
        with atomic_file(path, suffix=".png") as tmp, plt.rc_context(STYLE):
            fig.savefig(tmp, format="png")
    finally:
        plt.close(fig)
    return path
