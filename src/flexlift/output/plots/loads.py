"""Figures of the lift plan and the hull's longitudinal strength.

:func:`load_diagram` draws the bags on the hull with the loads they apply;
:func:`shear_moment_figure` draws V(x) and M(x) with their extremes marked. Both take
computed data and return a matplotlib Figure (never shown).
"""

from __future__ import annotations

import numpy as np
from matplotlib.patches import Ellipse, Polygon, Rectangle

from flexlift import constants as C
from flexlift.output.plots._style import new_figure

_EXT = "#c0392b"
_INT = "#2e86c1"
_WEIGHT = "#4a5568"
_HULL = "#1f4e79"


def _t(force: float, g: float) -> float:
    return force / (C.TONNE * g)


def load_diagram(hull, plan, case=None):
    """The hull in profile with its lift bags and loads.

    hull : :class:`~flexlift.structure.hull.Hull`; plan : :class:`~flexlift.loads.liftplan.LiftPlan`
    case : the :class:`~flexlift.loads.strength.LoadCase` (for the weight line load); optional
    """
    L, D = hull.length, hull.depth
    g = plan.gravity
    fig, ax = new_figure(figsize=(9.0, 4.2))
    # hull profile: raked stern and bow, keel at 0, deck at D
    prof = [(0.0, 0.35 * D), (0.03 * L, 0.0), (0.93 * L, 0.0), (L, 1.05 * D), (0.0, D)]
    ax.add_patch(Polygon(prof, closed=True, fc="#eef3f9", ec=_HULL, lw=1.4, zorder=1))
    # nodes
    xn = hull.x_nodes
    ax.plot(xn, np.full_like(xn, -0.15 * D), "|", color=_HULL, ms=6)
    step = max(1, hull.n_nodes // 14)
    for j in range(0, hull.n_nodes, step):
        ax.text(xn[j], -0.5 * D, str(j + 1), ha="center", va="top", fontsize=7, color=_HULL)
    ax.text(-0.01 * L, -0.5 * D, "node", ha="right", va="top", fontsize=7, color=_HULL)
    # internal bags: spans inside the hull
    for b in plan.internal:
        x0, x1 = b.span
        ax.add_patch(
            Rectangle((x0, 0.12 * D), x1 - x0, 0.78 * D, fc=_INT, ec="white", alpha=0.7, zorder=2)
        )
        ax.text(
            0.5 * (x0 + x1), 0.51 * D, f"{b.name}  {_t(b.lift, g):.0f} t",
            ha="center", va="center", fontsize=7.5, color="white", zorder=3,
        )
    # external bags: balloons on slings with an upward arrow
    top = D * 3.4
    for b in plan.external:
        ax.plot([b.x, b.x], [D, top - 0.9 * D], color=_EXT, lw=1.0, zorder=2)
        ax.add_patch(
            Ellipse((b.x, top), width=0.045 * L, height=1.7 * D, fc=_EXT, alpha=0.8, zorder=3)
        )
        ax.annotate(
            "", xy=(b.x, top + 1.9 * D), xytext=(b.x, top + 0.9 * D),
            arrowprops={"arrowstyle": "-|>", "color": _EXT, "lw": 1.4},
        )
        ax.text(
            b.x + 0.028 * L, top, f"{b.name}\n{_t(b.lift, g):.0f} t",
            fontsize=7.5, va="center", color=_EXT,
        )
    # weight: distributed arrows under the keel
    total_w = plan.breakout_factor * plan.wet_weight
    if case is not None:
        total_w = -sum(d.resultant for d in case.line_loads if d.resultant < 0) - sum(
            p.force for p in case.point_loads if p.force < 0
        )
    for xa in np.linspace(0.02 * L, 0.98 * L, 17):
        ax.annotate(
            "", xy=(xa, -1.9 * D), xytext=(xa, -1.0 * D),
            arrowprops={"arrowstyle": "-|>", "color": _WEIGHT, "lw": 0.9},
        )
    ax.plot([0.02 * L, 0.98 * L], [-1.0 * D, -1.0 * D], color=_WEIGHT, lw=0.9)
    ax.text(
        0.5 * L, -2.1 * D,
        f"downward {plan.breakout_factor:g} W' = {_t(total_w, g):.0f} t "
        f"({total_w / L / 1e3:.0f} kN/m over {L:g} m)",
        ha="center", va="top", fontsize=8, color=_WEIGHT,
    )
    ax.set_xlim(-0.06 * L, 1.1 * L)
    ax.set_ylim(-3.0 * D, top + 2.2 * D)
    ax.set_yticks([])
    ax.grid(False)
    ax.spines["left"].set_visible(False)
    ax.set_xlabel("x from the aft end [m]")
    short = f"; {_t(plan.shortfall, g):.0f} t SHORT" if plan.shortfall > 0 else ""
    ax.set_title(
        f"Lift plan: {plan.bag_count} bags, {_t(plan.total_lift, g):.0f} t of "
        f"{_t(plan.required_lift, g):.0f} t required{short}"
    )
    return fig


def shear_moment_figure(st, hull, plan=None):
    """Shear force [MN] and bending moment [MN m] along the hull, extremes marked.

    st : :class:`~flexlift.loads.strength.Strength`; hull : the beam; plan : optional, to mark bags
    """
    fig, (ax1, ax2) = new_figure(2, 1, sharex=True, figsize=(8.5, 5.6))
    x = st.x
    scale = 1e6
    for ax, y, ext, unit, label, sym in (
        (ax1, st.V, st.max_shear, "MN", "shear force V", "V"),
        (ax2, st.M, st.max_moment, "MN m", "bending moment M (sagging +)", "M"),
    ):
        ax.plot(x, y / scale, color=_HULL, lw=1.4)
        ax.fill_between(x, 0, y / scale, color=_HULL, alpha=0.12)
        ax.axhline(0, color="black", lw=0.6)
        ax.plot(ext.x, ext.value / scale, "o", color=_EXT, ms=6, zorder=4)
        ax.annotate(
            f"max |{sym}| = {abs(ext.value) / scale:.2f} {unit}\n"
            f"x = {ext.x:.2f} m (node {ext.node})",
            # beside the extreme at its own level: the curve lies on the other side there
            xy=(ext.x, ext.value / scale),
            xytext=(-14 if ext.x > 0.7 * hull.length else 14, 0),
            textcoords="offset points", fontsize=8, color=_EXT, va="center",
            ha="right" if ext.x > 0.7 * hull.length else "left",
            bbox={"fc": "white", "ec": "none", "alpha": 0.85, "pad": 1.5},
        )
        ax.set_ylabel(f"{label} [{unit}]")
        if plan is not None:
            for b in plan.external:
                ax.axvline(b.x, color=_EXT, lw=0.6, ls=":")
            for b in plan.internal:
                ax.axvspan(*b.span, color=_INT, alpha=0.06, lw=0)
    ax1.set_title(
        f"Longitudinal strength: closing V = {st.closing_shear / 1e6:.3f} MN, "
        f"M = {st.closing_moment / 1e6:.3f} MN m at the bow"
    )
    top = ax1.secondary_xaxis("top")
    step = max(1, hull.n_nodes // 14)
    top.set_xticks(hull.x_nodes[::step], [str(j + 1) for j in range(0, hull.n_nodes, step)])
    top.set_xlabel("node", fontsize=8)
    ax2.set_xlabel("x from the aft end [m]")
    ax2.set_xlim(0, hull.length)
    return fig
