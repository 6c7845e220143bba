"""The sweep's figures: distributions of the headline numbers, and the keys' influence.

Each function takes the records (or the summary) and returns a matplotlib figure; the report
embeds it (:func:`png`).
"""

from __future__ import annotations

import io

import numpy as np

from flexlift.output.plots._style import STYLE
from flexlift.sweep import aggregate as agg

#: the headline numbers drawn, with their labels (others are listed in the dataset)
SHOWN = {"max_ascent_velocity_ms": "max ascent velocity [m/s]",
         "max_descent_velocity_ms": "max descent velocity [m/s]",
         "max_pitch_deg": "max pitch [deg]",
         "max_utilisation": "max hull stress / allowable",
         "max_bending_moment_MNm": "max bending moment [MN m]",
         "gas_total_free_air_m3": "gas used in all, free air [m3]",
         "separation_time_s": "separation time [s]",
         "end_time_s": "end of the run [s]"}
#: the panels of the CDF figure, in order (those the headline has)
CDF_PANELS = 6


def new_figure(nrows: int, ncols: int, figsize, left: float = 0.08, top: float = 0.97, **kw):
    """A figure in the house style with a fixed layout (a sweep's report is drawn after every
    run, and resumed runs redraw it: matplotlib's constrained layout would double its cost).
    A :class:`~matplotlib.figure.Figure` on an Agg canvas, not pyplot's: the caller's pyplot
    backend is left alone (flexlift.output.plots._style.new_figure)."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    with matplotlib.rc_context(STYLE):
        fig = Figure(figsize=figsize)
        FigureCanvasAgg(fig)
        axes = fig.subplots(nrows, ncols, **kw)
    fig.subplots_adjust(left=left, right=0.96, bottom=0.12 / nrows ** 0.5, top=top,
                        wspace=0.3, hspace=0.45)
    return fig, axes


def png(fig) -> bytes:
    """The figure as PNG bytes (closed afterwards, if pyplot made it)."""
    import matplotlib
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    try:
        with matplotlib.rc_context(STYLE):
            fig.savefig(buf, format="png")
    finally:
        plt.close(fig)
    return buf.getvalue()


def cdfs(records: dict, modes, limits: dict):
    """Empirical CDFs of the headline numbers, one panel each, one line per control mode,
    with the limit as a dashed line where there is one; None when nothing completed."""
    names = [n for n in SHOWN if any(np.isfinite(agg.headline_array(records, m, n)).any()
                                     for m in modes)][:CDF_PANELS]
    if not names:
        return None
    cols = 3
    rows = -(-len(names) // cols)
    fig, axes = new_figure(rows, cols, figsize=(9.0, 2.6 * rows), squeeze=False)
    for ax, name in zip(axes.flat, names):
        for m in modes:
            v = np.sort(agg.headline_array(records, m, name))
            v = v[np.isfinite(v)]
            if v.size:
                ax.step(v, np.arange(1, v.size + 1) / v.size, where="post", label=m)
        if name in limits:
            ax.axvline(limits[name], color="#b42318", ls="--", lw=1, label="limit")
        ax.set_xlabel(SHOWN[name])
        ax.set_ylabel("fraction of cases")
        ax.set_ylim(0, 1.02)
    for ax in list(axes.flat)[len(names):]:
        ax.set_visible(False)
    axes.flat[0].legend(loc="lower right")
    return fig


#: the headline numbers of the tornado plot
TORNADO = ("max_ascent_velocity_ms", "max_pitch_deg", "max_utilisation")


def tornado(headline_sensitivity: dict, mode: str, keys):
    """Rank correlation of every varied key with three headline numbers of ``mode`` (speed,
    pitch, hull stress), keys sorted by their largest influence; None when nothing could
    be ranked."""
    sens = {n: dict(map(tuple, headline_sensitivity.get(mode, {}).get(n, []))) for n in TORNADO}
    sens = {n: s for n, s in sens.items() if s}
    if not sens or not keys:
        return None
    names = list(sens)
    width = max(len(k) for k in keys)
    height = 0.5 * len(keys) * len(names) / 2 + 1.6
    fig, ax = new_figure(1, 1, figsize=(7.5, height), left=min(0.55, 0.02 + 0.0115 * width),
                         top=1 - 0.45 / height)
    order = sorted(keys, key=lambda k: max(abs(sens[n].get(k, 0.0)) for n in names))
    y = np.arange(len(order))
    h = 0.8 / len(names)
    for j, n in enumerate(names):
        vals = np.array([sens[n].get(k, 0.0) for k in order])
        ax.barh(y - (j - (len(names) - 1) / 2) * h, vals, height=h, label=SHOWN[n])
    ax.axvline(0, color="#4a5568", lw=0.8)
    ax.set_xlim(-1, 1)
    ax.set_yticks(y, order)
    ax.set_xlabel("Spearman rank correlation with the headline number")
    fig.legend(loc="upper center", ncol=len(names))
    return fig


def convergence(curve: dict):
    """Each probability against the number of cases, its 95 % Wilson interval shaded."""
    ns = np.asarray(curve.get("n", []), dtype=float)
    names = [k for k in curve if k != "n"]
    if ns.size < 2 or not names:
        return None
    fig, ax = new_figure(1, 1, (7.5, 3.6), left=0.1)
    for k in names:
        a = np.asarray([[np.nan if v is None else v for v in row] for row in curve[k]], float)
        line, = ax.plot(ns, a[:, 0], label=k.replace("_", " "))
        ax.fill_between(ns, a[:, 1], a[:, 2], color=line.get_color(), alpha=0.15, lw=0)
    ax.set_xscale("log")
    ax.set_xlabel("cases")
    ax.set_ylabel("probability")
    ax.set_ylim(0, 1)
    ax.legend(fontsize=7, ncol=2)
    return fig
