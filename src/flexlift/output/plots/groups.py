"""Lift points on a figure: colours by position along the hull and a legend of a dozen
entries at most, whatever the number of bags."""

from __future__ import annotations

import matplotlib
import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

#: the most entries a legend holds; more lift points are told apart by the colour bar
MAX_LEGEND = 12
#: the colour map of position along the hull (its last tenth, too pale on white, is unused)
CMAP = matplotlib.colormaps["viridis"].resampled(256)
_TOP = 0.9


def point_colours(points, length: float):
    """(one colour per lift point, a mappable for the colour bar in metres): position along
    the hull, 0 (aft end) to ``length`` [m]."""
    norm = Normalize(0.0, max(float(length), 1e-9))
    cmap = matplotlib.colors.ListedColormap(CMAP(np.linspace(0.0, _TOP, 256)))
    colours = [cmap(norm(p.x)) for p in points]
    return colours, ScalarMappable(norm=norm, cmap=cmap)


def point_legend(ax, points, **kw):
    """The lift points by name when there are at most :data:`MAX_LEGEND` of them (a
    cluster with its count), else the line styles only; returns the legend."""
    if len(points) <= MAX_LEGEND:
        labels = {p.label: (f"{p.label} ({p.count})" if p.count > 1 else p.label)
                  for p in points}
        lines = {ln.get_label(): ln for ln in ax.get_lines() if ln.get_label() in labels}
        handles = [lines[p.label] for p in points if p.label in lines]
        texts = [labels[p.label] for p in points if p.label in lines]
        return ax.legend(handles, texts, ncols=4, loc="upper left", fontsize=7.5, **kw)
    handles = [Line2D([], [], color="0.3", ls="-", label="external lift point: mean of its bags")]
    if any(p.count > 1 for p in points):
        handles.append(Patch(color="0.3", alpha=0.25, label="spread of its bags"))
    if any(p.kind == "internal" for p in points):
        handles.append(Line2D([], [], color="0.3", ls="--", label="internal bag"))
    return ax.legend(handles=handles, ncols=len(handles), loc="upper left", fontsize=7.5,
                     title=f"{len(points)} lift points, coloured by x", title_fontsize=7.5, **kw)
