"""The sweep's figures: distributions of the headline numbers, and the keys' influence.

Each function takes the records (or the summary) and returns a matplotlib figure; the report
embeds it (:func:`png`).
"""

from __future__ import annotations

import io

import numpy as np

from flexlift.output.plots._style import STYLE, new_figure
from flexlift.sweep import aggregate as agg

#: the headline numbers drawn, with their labels (others are listed in the dataset)
SHOWN = {"max_ascent_velocity_ms": "max ascent velocity [m/s]",
         "max_pitch_deg": "max pitch [deg]",
         "max_bending_moment_MNm": "max bending moment [MN m]",
         "gas_used_free_air_m3": "gas used, free air [m3]",
         "separation_time_s": "separation time [s]",
         "end_time_s": "end of the run [s]"}


def png(fig) -> bytes:
    """The figure as PNG bytes (closed afterwards)."""
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    try:
        with plt.rc_context(STYLE):
            fig.savefig(buf, format="png")
    finally:
        plt.close(fig)
    return buf.getvalue()


def cdfs(records: dict, modes, limits: dict):
    """Empirical CDFs of the headline numbers, one panel each, one line per control mode,
    with the limit as a dashed line where there is one; None when nothing completed."""
    names = [n for n in SHOWN if any(np.isfinite(agg.headline_array(records, m, n)).any()
                                     for m in modes)]
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


def tornado(headline_sensitivity: dict, mode: str, keys):
    """Rank correlation of every varied key with the headline numbers of ``mode``: one panel
    per number, keys sorted by influence; None when nothing could be ranked."""
    sens = {n: dict(map(tuple, headline_sensitivity.get(mode, {}).get(n, []))) for n in SHOWN}
    sens = {n: s for n, s in sens.items() if s}
    if not sens or not keys:
        return None
    names = list(sens)[:4]
    fig, axes = new_figure(1, len(names), figsize=(2.6 * len(names) + 1.8, 0.45 * len(keys) + 1.6),
                           squeeze=False, sharey=True)
    order = sorted(keys, key=lambda k: max(abs(sens[n].get(k, 0.0)) for n in names))
    y = np.arange(len(order))
    for ax, n in zip(axes.flat, names):
        vals = np.array([sens[n].get(k, 0.0) for k in order])
        ax.barh(y, vals, color=np.where(vals >= 0, "#1f4e79", "#d69e2e"))
        ax.axvline(0, color="#4a5568", lw=0.8)
        ax.set_xlim(-1, 1)
        ax.set_title(SHOWN[n], fontsize=9)
        ax.set_xlabel("rank correlation")
    axes.flat[0].set_yticks(y, order)
    return fig
