"""Figures of a simulated ascent (take a :class:`~flexlift.ascent.result.Result`, return a figure).

Time is in seconds everywhere (as in the events, the criteria and the CSV). The time
histories show the ascent itself, from :data:`BEFORE_SEPARATION_S` before the first
separation to the end of the run (:func:`zoom_window`): the filling and the wait for breakout
before it (half an hour on the tanker) are one overview panel of the bags' heights.
"""

from __future__ import annotations

import numpy as np

from flexlift.output.plots._style import new_figure

_PANELS = (
    ("height", 1.0, "height [m]"),
    ("ascent_velocity", 1.0, "ascent velocity [m/s]"),
    ("pitch_angle", 180 / np.pi, "pitch angle [deg]"),
    ("pitch_rate", 180 / np.pi, "pitch rate [deg/s]"),
    ("net_flow", 1.0, "net flow [m³/s]"),
)
#: the zoomed time histories start this long before the first separation [s]
BEFORE_SEPARATION_S = 60.0
_TIME = "time [s]"


def zoom_window(result) -> tuple[float, float]:
    """(start, end) of the zoomed time histories [s]: from :data:`BEFORE_SEPARATION_S`
    before the first separation (never before 0) to the end of the run; the whole run when
    the hull never separated."""
    t = result.dataset.time.values
    end = float(t[-1]) if t.size else 0.0
    sep = result.event_time("separation")
    if sep is None:
        return 0.0, end
    return max(0.0, float(sep) - BEFORE_SEPARATION_S), end


def window_text(result) -> str:
    """The zoom window in words, for captions."""
    t0, t1 = zoom_window(result)
    if result.event_time("separation") is None:
        return f"the whole run, 0 to {t1:.0f} s (the hull never separated)"
    return (f"{t0:.0f} to {t1:.0f} s: from {BEFORE_SEPARATION_S:.0f} s before the first "
            "separation to the end of the run")


def _in(t: np.ndarray, t0: float, t1: float) -> np.ndarray:
    """Indices of ``t`` in [t0, t1] plus one sample either side (the curve reaches the edge)."""
    i0 = max(int(np.searchsorted(t, t0, side="right")) - 1, 0)
    i1 = min(int(np.searchsorted(t, t1, side="left")) + 1, t.size)
    return slice(i0, i1)


def _event_lines(ax, result, kinds=("separation", "breakout")):
    for e in result.events:
        if e["kind"] in kinds:
            ax.axvline(e["time_s"], color="0.45", lw=0.7, ls=":")


def bag_histories(result):
    """The paper's five time histories (height, ascent velocity, pitch angle, pitch rate, net
    flow) over :func:`zoom_window`, under an overview of the heights over the whole run with
    that window shaded: one line per lift point (:mod:`flexlift.output.liftpoints`; the mean
    of its bags, their spread as a band), coloured by the point's position along the hull
    (colour bar in metres), dashed for an internal bag; the legend names the points when
    there are at most :data:`~flexlift.output.plots.groups.MAX_LEGEND`, else the line styles."""
    from flexlift.output.liftpoints import lift_points, point_stats
    from flexlift.output.plots.groups import point_colours, point_legend

    ds = result.dataset
    t = ds.time.values
    t0, t1 = zoom_window(result)
    fig, axes = new_figure(6, 1, figsize=(8.0, 11.0), height_ratios=[0.7, 1, 1, 1, 1, 1],
                           margins={"top": 0.45, "hgap": 0.5, "right": 0.95})
    points = lift_points(ds)
    colours, mappable = point_colours(points, _hull_length(ds))
    over = axes[0]
    w = _in(t, t0, t1)
    for ax, (name, scale, _), part in zip(axes, (("height", 1.0, ""),) + _PANELS,
                                          [slice(None)] + [w] * len(_PANELS)):
        values = ds[name].values
        for p, c in zip(points, colours):
            mean, lo, hi = point_stats(values[part], p)
            ls = "-" if p.kind == "external" else "--"
            ax.plot(t[part], mean * scale, ls, color=c, lw=1.0, label=p.label)
            if p.count > 1:
                ax.fill_between(t[part], lo * scale, hi * scale, color=c, alpha=0.25, lw=0)
    over.axvspan(t0, t1, color="C0", alpha=0.07, lw=0)
    over.set_xlim(0.0, max(t1, 1e-9))
    over.set_ylabel("height [m]\n(whole run)")
    over.set_xlabel(_TIME, labelpad=1)
    point_legend(over, points)
    cax = over.inset_axes([1.015, 0.0, 0.018, 1.0])
    fig.colorbar(mappable, cax=cax, label="lift point x [m]")
    _event_lines(over, result)
    for ax, (_, _, label) in zip(axes[1:], _PANELS):
        ax.set_ylabel(label)
        ax.set_xlim(t0, t1)
        _event_lines(ax, result)
    for ax in axes[1:-1]:
        ax.tick_params(labelbottom=False)
    axes[-1].set_xlabel(_TIME)
    over.text(0.5 * (t0 + t1), 0.25, "shown below", transform=over.get_xaxis_transform(),
              ha="center", va="center", fontsize=8, color="C0")
    over.set_title(f"Bag histories by lift point, {result.control} control "
                   "(dotted: separation, breakout)")
    return fig


def _hull_length(ds) -> float:
    """The hull's length [m] as far as the result knows it (its strength grid, else the
    farthest bag)."""
    if "x" in ds.coords and ds.x.size:
        return float(ds.x.values[-1])
    return float(np.max(ds.bag_x.values)) if ds.bag.size else 1.0


def hull_motion(result):
    """Hull heave and pitch over :func:`zoom_window`."""
    ds = result.dataset
    t = ds.time.values
    t0, t1 = zoom_window(result)
    w = _in(t, t0, t1)
    fig, (a1, a2) = new_figure(2, 1, figsize=(8.0, 5.0), sharex=True)
    a1.plot(t[w], ds.heave.values[w])
    a1.set_ylabel("heave [m]")
    a2.plot(t[w], np.degrees(ds.pitch.values[w]))
    a2.set_ylabel("pitch [deg, bow up]")
    a2.set_xlabel(_TIME)
    a2.set_xlim(t0, t1)
    for ax in (a1, a2):
        _event_lines(ax, result)
    a1.set_title(f"Hull heave and pitch, {result.control} control, {t0:.0f} to {t1:.0f} s")
    return fig


def moment_map(result):
    """Bending-moment envelope along the hull (the whole run) and a time-x map of the
    bending moment over :func:`zoom_window`."""
    ds = result.dataset
    fig, (a1, a2) = new_figure(1, 2, figsize=(10.0, 4.2), margins={"wgap": 0.9, "right": 0.3})
    x = ds.x.values
    a1.fill_between(x, ds.moment_min.values / 1e6, ds.moment_max.values / 1e6, alpha=0.3,
                    label="envelope")
    a1.plot(x, ds.moment_max.values / 1e6, lw=1)
    a1.plot(x, ds.moment_min.values / 1e6, lw=1)
    a1.set_xlabel("x from the aft end [m]")
    a1.set_ylabel("bending moment [MN m, sagging +]")
    a1.set_title("Bending-moment envelope, whole run")
    ts = ds.time_strength.values
    t0, t1 = zoom_window(result)
    w = _in(ts, t0, t1)
    M = ds.bending_moment.values / 1e6
    lim = float(np.abs(M).max()) or 1.0
    mesh = a2.pcolormesh(x, ts[w], M[w], cmap="RdBu_r", vmin=-lim, vmax=lim,
                         shading="nearest", rasterized=True)
    fig.colorbar(mesh, ax=a2, label="MN m", pad=0.02)
    a2.set_xlabel("x from the aft end [m]")
    a2.set_ylabel(_TIME)
    a2.set_title(f"Bending moment in time, {result.control} control")
    a2.grid(False)
    return fig


def seabed_and_stress(result, validity_deg: float, x=None, utilisation=None):
    """A long structure's lift: where it lies on the seabed in time (the touchdown points),
    its largest slope in time against the small-deflection beam's validity, and the
    bending-stress utilisation along it: the envelope over the lift and, given ``x`` [m] and
    ``utilisation`` [-], the governing static design case of the loads stage."""
    ds = result.dataset
    ts = ds.time_strength.values
    t0, t1 = zoom_window(result)
    w = _in(ts, t0, t1)
    fig, (a1, a2, a3) = new_figure(3, 1, figsize=(8.0, 8.0), margins={"hgap": 0.65})
    lo, hi = ds.grounded_from.values[w], ds.grounded_to.values[w]
    a1.fill_between(ts[w], lo, hi, step="mid", alpha=0.35, color="C5", label="on the seabed")
    a1.plot(ts[w], lo, color="C5", lw=1, label="touchdown points")
    a1.plot(ts[w], hi, color="C5", lw=1)
    a1.set_ylim(0.0, float(ds.x.values[-1]))
    a1.set(xlabel=_TIME, ylabel="x along the structure [m]",
           title=f"On the seabed, {result.control} control (touchdown points in time)")
    a1.legend(loc="upper left")
    a2.plot(ts[w], np.degrees(ds.slope_largest.values[w]), label="largest slope")
    a2.axhline(validity_deg, color="C3", ls="--", lw=1,
               label=f"small-deflection validity, {validity_deg:g} deg")
    a2.set(xlabel=_TIME, ylabel="slope [deg]", title="Largest slope along the structure")
    a2.legend(loc="upper right")
    for ax in (a1, a2):
        ax.set_xlim(t0, t1)
        _event_lines(ax, result)
    top = float(ds.utilisation_max.values.max())
    a3.plot(ds.x.values, ds.utilisation_max.values, label="envelope over the lift")
    if x is not None:
        a3.plot(x, utilisation, color="C2", lw=1, label="static design case (the loads stage)")
        top = max(top, float(np.max(utilisation)))
    a3.axhline(1.0, color="C3", ls="--", lw=1, label="allowable")
    a3.set(xlabel="x along the structure [m]", ylabel="utilisation σ / σ_allow [-]",
           title="Bending-stress utilisation")
    a3.set_ylim(0.0, max(1.1, 1.05 * top))
    a3.legend(loc="upper right")
    return fig


#: the variables :func:`compare` reads of each result
COMPARED = ("heave", "pitch", "ascent_velocity", "moment_max", "moment_min")


def compare(results):
    """Several control modes on one figure: mean height, hull pitch, fastest bag velocity over
    the union of their zoom windows, and the bending-moment envelopes."""
    fig, axes = new_figure(2, 2, figsize=(10.0, 6.8), margins={"wgap": 0.9, "hgap": 0.8})
    (a1, a2), (a3, a4) = axes
    windows = np.array([zoom_window(r) for r in results])
    t0, t1 = float(windows[:, 0].min()), float(windows[:, 1].max())
    for r in results:
        ds = r.dataset
        t = ds.time.values
        w = _in(t, t0, t1)
        a1.plot(t[w], ds.heave.values[w], label=r.control)
        a2.plot(t[w], np.degrees(ds.pitch.values[w]), label=r.control)
        a3.plot(t[w], np.abs(ds.ascent_velocity.values[w]).max(axis=1), label=r.control)
        if "x" in ds.coords:
            a4.plot(ds.x.values, np.maximum(np.abs(ds.moment_max.values),
                                            np.abs(ds.moment_min.values)) / 1e6, label=r.control)
    a1.set_ylabel("heave [m]")
    a2.set_ylabel("pitch [deg]")
    a3.set_ylabel("fastest bag point [m/s]")
    a4.set_ylabel("|bending moment| envelope [MN m]")
    for ax in (a1, a2, a3):
        ax.set_xlabel(_TIME)
        ax.set_xlim(t0, t1)
    a4.set_xlabel("x from the aft end [m]")
    a1.legend()
    a1.set_title(f"Control modes compared, {t0:.0f} to {t1:.0f} s")
    a4.set_title("Bending-moment envelopes, whole run")
    return fig
