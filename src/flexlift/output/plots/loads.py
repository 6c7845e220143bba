"""Figures of the lift plan and the hull's longitudinal strength.

:func:`load_diagram` draws the bags on the hull with the loads they apply;
:func:`shear_moment_figure` draws V(x) and M(x) with their extremes marked. Both take
computed data and return a matplotlib Figure (never shown).
"""

from __future__ import annotations

import numpy as np
from matplotlib.patches import Ellipse, Polygon, Rectangle

from flexlift import constants as C
from flexlift.loads.strength import LoadCase
from flexlift.output.plots._style import new_figure

_EXT = "#c0392b"
_INT = "#2e86c1"
_WEIGHT = "#4a5568"
_HULL = "#1f4e79"


def _t(force: float, g: float) -> float:
    return force / (C.TONNE * g)


#: the diagram's size [in] and the label font [pt]
_SIZE = (9.0, 4.8)
_FONT = 7.5
#: average advance of a DejaVu Sans character, in ems (for the label widths before drawing)
_EM = 0.62


def _names(names: list[str]) -> str:
    """A compact list of bag names: "bag_1..bag_3" for a consecutive run, else the names."""
    if len(names) == 1:
        return names[0]
    stem = [n.rpartition("_") for n in names]
    if all(s[0] == stem[0][0] and s[2].isdigit() for s in stem):
        k = [int(s[2]) for s in stem]
        if k == list(range(k[0], k[0] + len(k))):
            return f"{names[0]}..{names[-1]}"
    return ", ".join(names[:3]) + (f" +{len(names) - 3}" if len(names) > 3 else "")


def _lanes(items: list[tuple[float, float]]) -> list[int]:
    """Greedy lanes for labels given as (centre, width) in data units: each label takes the
    lowest lane where it clears (by a 5 % margin) every label already placed there."""
    ends: list[list[tuple[float, float]]] = []
    out = [0] * len(items)
    for i in sorted(range(len(items)), key=lambda i: items[i][0]):
        c, w = items[i]
        lo, hi = c - 0.55 * w, c + 0.55 * w
        for lane, taken in enumerate(ends):
            if all(hi <= a or lo >= b for a, b in taken):
                taken.append((lo, hi))
                out[i] = lane
                break
        else:
            ends.append([(lo, hi)])
            out[i] = len(ends) - 1
    return out


def _text_width(text: str, data_per_inch: float) -> float:
    longest = max(len(line) for line in text.split("\n"))
    return longest * _EM * _FONT / 72.0 * data_per_inch


def _weights(case, hull):
    """The downward loads of the load case: the line load q(x) >= 0 [N/m] sampled on x [m]
    (every end of a load twice, the limits from aft and from forward: steps stay steps), its
    exact total [N], and the point loads (x [m], force >= 0 [N]) of the point masses."""
    L = hull.length
    down = tuple(d for d in case.line_loads if d.resultant < 0) if case is not None else ()
    points = [(p.x, -p.force) for p in case.point_loads if p.force < 0] if case else []
    edges = np.array(sorted({e for d in down for e in (d.x0, d.x1)}))
    grid = np.unique(np.concatenate([np.linspace(0.0, L, 201), edges]))
    twice = np.isin(grid, edges)
    x = np.repeat(grid, np.where(twice, 2, 1))
    first = np.cumsum(np.where(twice, 2, 1)) - np.where(twice, 2, 1)
    from_aft = np.zeros(x.size, dtype=bool)
    from_aft[first[twice]] = True
    q = -LoadCase(L, down).line_load(x, from_aft) if down else np.zeros_like(x)
    return x, q, -sum(d.resultant for d in down), points


def _draw_weight(ax, hull, plan, case, D: float) -> float:
    """The distributed weight as a load curve under the keel (depth proportional to q), its
    arrows, and the point masses as heavier arrows with their tonnes; returns the total [N]."""
    g, L = plan.gravity, hull.length
    x, q, distributed, points = _weights(case, hull)
    base, depth = -0.85 * D, 0.8 * D
    qmax = float(q.max()) if q.size and q.max() > 0 else 1.0
    if q.max() > 0:
        ax.fill_between(x, base, base - depth * q / qmax, color=_WEIGHT, alpha=0.15, lw=0)
        ax.plot(x, base - depth * q / qmax, color=_WEIGHT, lw=0.9)
        xa = np.linspace(0.02 * L, 0.98 * L, 17)
        qa = np.interp(xa, x, q)
        xa, qa = xa[qa > 0], qa[qa > 0]
        ax.quiver(xa, np.full_like(xa, base), np.zeros_like(xa), -depth * qa / qmax, color=_WEIGHT,
                  angles="xy", scale_units="xy", scale=1.0, width=0.0018, headwidth=5,
                  headlength=5, headaxislength=4.5)  # one artist for every arrow
    ax.plot([0.0, L], [base, base], color=_WEIGHT, lw=0.9)
    fmax = max((f for _, f in points), default=0.0)
    for xp, f in points:
        ax.annotate("", xy=(xp, base - 1.3 * D * (0.5 + 0.5 * f / fmax)), xytext=(xp, base),
                    arrowprops={"arrowstyle": "-|>", "color": _HULL, "lw": 2.0})
        ax.text(xp + 0.01 * L, base - 1.3 * D, f"{_t(f, g):.0f} t", fontsize=_FONT,
                color=_HULL, va="center", gid="point-mass-label")
    total = distributed + sum(f for _, f in points)
    qmin = float(q[q > 0].min()) if (q > 0).any() else 0.0
    kn = f"{qmin / 1e3:.0f}–{qmax / 1e3:.0f} kN/m" if qmin < 0.99 * qmax else \
        f"{qmax / 1e3:.0f} kN/m"
    pm = (f" + point masses {_t(total - distributed, g):.0f} t (heavy arrows)"
          if points else "")
    ax.text(0.5 * L, base - 1.5 * D,
            f"downward {plan.breakout_factor:g} W' = {_t(total, g):.0f} t: distributed "
            f"{_t(distributed, g):.0f} t as the mass ({kn}){pm}",
            ha="center", va="top", fontsize=8, color=_WEIGHT)
    return total


def _draw_internal(ax, plan, D: float, data_per_inch: float) -> list[tuple[float, str]]:
    """Internal bags as spans inside the hull, labelled inside when the label fits; returns
    the (x, label) of those that do not (they go in lanes above the deck)."""
    g = plan.gravity
    outside = []
    for b in plan.internal:
        x0, x1 = b.span
        ax.add_patch(Rectangle((x0, 0.12 * D), x1 - x0, 0.78 * D, fc=_INT, ec="white",
                               alpha=0.7, zorder=2))
        label = f"{b.name}  {_t(b.lift, g):.0f} t"
        if _text_width(label, data_per_inch) < 0.92 * (x1 - x0):
            ax.text(0.5 * (x0 + x1), 0.51 * D, label, ha="center", va="center",
                    fontsize=_FONT, color="white", zorder=3, gid="bag-label")
        else:
            outside.append((0.5 * (x0 + x1), f"{b.name}\n{_t(b.lift, g):.0f} t"))
    return outside


def _draw_external(ax, plan, hull, top: float, D: float) -> list[tuple[float, str]]:
    """External bags as balloons on slings with an upward arrow, one balloon per lift point
    (a cluster's count written in it); returns each lift point's (x, label)."""
    g, L = plan.gravity, hull.length
    lift = {b.name: b.lift for b in plan.external}
    labels = []
    for x, names in plan.lift_points():
        ax.plot([x, x], [D, top - 0.9 * D], color=_EXT, lw=1.0, zorder=2)
        ax.add_patch(Ellipse((x, top), width=0.045 * L, height=1.7 * D, fc=_EXT, alpha=0.8,
                             zorder=3))
        ax.annotate("", xy=(x, top + 1.9 * D), xytext=(x, top + 0.9 * D),
                    arrowprops={"arrowstyle": "-|>", "color": _EXT, "lw": 1.4})
        each = {round(_t(lift[n], g)) for n in names}
        if len(names) > 1:
            ax.text(x, top, f"×{len(names)}", ha="center", va="center", fontsize=_FONT,
                    color="white", zorder=4)
            tonnes = (f"{len(names)} × {each.pop():.0f} t" if len(each) == 1 else
                      f"{sum(_t(lift[n], g) for n in names):.0f} t")
        else:
            tonnes = f"{_t(lift[names[0]], g):.0f} t"
        labels.append((x, f"{_names(names)}\n{tonnes}"))
    return labels


def _place_labels(ax, labels, y0: float, step: float, color: str, dpi: float) -> int:
    """Labels centred on their x in lanes from ``y0`` upward (``step`` apart) so that no two
    overlap; returns the number of lanes used."""
    if not labels:
        return 0
    lanes = _lanes([(x, _text_width(t, dpi)) for x, t in labels])
    for (x, text), lane in zip(labels, lanes):
        ax.text(x, y0 + lane * step, text, ha="center", va="bottom", fontsize=_FONT,
                color=color, zorder=5, gid="bag-label", linespacing=1.1)
    return max(lanes) + 1


def load_diagram(hull, plan, case=None):
    """The hull in profile with its lift bags and loads: bag labels in lanes that never
    overlap, the weight drawn as the load case distributes it (with the mass, point masses
    as heavy arrows).

    hull : :class:`~flexlift.structure.hull.Hull`; plan : :class:`~flexlift.loads.liftplan.LiftPlan`
    case : the :class:`~flexlift.loads.strength.LoadCase` (the weight as distributed); optional
    """
    L, D = hull.length, hull.depth
    g = plan.gravity
    fig, ax = new_figure(figsize=_SIZE, margins={"left": 0.3, "right": 0.2, "top": 0.35})
    m = fig._flexlift_margins
    xlim = (-0.06 * L, 1.1 * L)
    data_per_inch = (xlim[1] - xlim[0]) / (_SIZE[0] - m["left"] - m["right"])
    prof = [(0.0, 0.35 * D), (0.03 * L, 0.0), (0.93 * L, 0.0), (L, 1.05 * D), (0.0, D)]
    ax.add_patch(Polygon(prof, closed=True, fc="#eef3f9", ec=_HULL, lw=1.4, zorder=1))
    xn = hull.x_nodes
    ax.plot(xn, np.full_like(xn, -0.15 * D), "|", color=_HULL, ms=6)
    step = max(1, hull.n_nodes // 14)
    for j in range(0, hull.n_nodes, step):
        ax.text(xn[j], -0.35 * D, str(j + 1), ha="center", va="top", fontsize=7, color=_HULL)
    ax.text(-0.01 * L, -0.35 * D, "node", ha="right", va="top", fontsize=7, color=_HULL)
    inside_lanes = _place_labels(ax, _draw_internal(ax, plan, D, data_per_inch), 1.15 * D,
                                 0.75 * D, _INT, data_per_inch)
    top = D * (3.4 + 0.75 * max(0, inside_lanes - 1))
    ext = _place_labels(ax, _draw_external(ax, plan, hull, top, D), top + 2.05 * D, 0.85 * D,
                        _EXT, data_per_inch)
    _draw_weight(ax, hull, plan, case, D)
    ax.set_xlim(*xlim)
    ax.set_ylim(-3.0 * D, top + 2.05 * D + 0.85 * D * max(ext, 1) + 0.2 * D)
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


#: colours of the design cases' curves, in order
_CASE_COLOURS = (_HULL, "#d68910", _EXT, "#7d3c98")


def shear_moment_figure(st, hull, plan=None):
    """Shear force [MN] and bending moment [MN m] along the hull, the peak marked.

    st : a :class:`~flexlift.loads.strength.Strength`, or a sequence of (label, Strength), one
        per design case, drawn together (the peak marked is the largest over them)
    hull : the beam; plan : optional, to mark bags
    """
    curves = [("", st)] if not isinstance(st, (list, tuple)) else list(st)
    fig, (ax1, ax2) = new_figure(2, 1, sharex=True, figsize=(8.5, 5.8), margins={"top": 0.85})
    scale = 1e6
    for ax, attr, ext_attr, unit, label, sym in (
        (ax1, "V", "max_shear", "MN", "shear force V", "V"),
        (ax2, "M", "max_moment", "MN m", "bending moment M (sagging +)", "M"),
    ):
        for k, (name, s) in enumerate(curves):
            y = getattr(s, attr)
            colour = _CASE_COLOURS[k % len(_CASE_COLOURS)]
            ax.plot(s.x, y / scale, color=colour, lw=1.4, label=name or None)
            if len(curves) == 1:
                ax.fill_between(s.x, 0, y / scale, color=colour, alpha=0.12)
        k_peak = max(range(len(curves)), key=lambda k: abs(getattr(curves[k][1], ext_attr).value))
        ext = getattr(curves[k_peak][1], ext_attr)
        which = f" ({curves[k_peak][0]})" if curves[k_peak][0] else ""
        ax.axhline(0, color="black", lw=0.6)
        ax.plot(ext.x, ext.value / scale, "o", color=_EXT, ms=6, zorder=4)
        ax.annotate(
            f"max |{sym}| = {abs(ext.value) / scale:.2f} {unit}{which}\n"
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
    if len(curves) > 1:
        ax2.legend(fontsize=7, loc="best", frameon=False)
    worst_V = max(abs(s.closing_shear) for _, s in curves)
    worst_M = max(abs(s.closing_moment) for _, s in curves)
    ax1.set_title(
        f"Longitudinal strength: {'largest ' if len(curves) > 1 else ''}closing |V| = "
        f"{worst_V / 1e6:.3g} MN, |M| = {worst_M / 1e6:.3g} MN m at the bow",
        pad=34,  # over the node numbers of the top axis and their label
    )
    top = ax1.secondary_xaxis("top")
    step = max(1, hull.n_nodes // 14)
    top.set_xticks(hull.x_nodes[::step], [str(j + 1) for j in range(0, hull.n_nodes, step)])
    top.set_xlabel("node", fontsize=8)
    ax2.set_xlabel("x from the aft end [m]")
    ax2.set_xlim(0, hull.length)
    return fig
