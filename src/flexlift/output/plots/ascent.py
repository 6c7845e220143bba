"""Figures of a simulated ascent (take a :class:`~flexlift.ascent.result.Result`, return a figure)."""

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


def _event_lines(ax, result, kinds=("separation", "breakout")):
    for e in result.events:
        if e["kind"] in kinds:
            ax.axvline(e["time_s"] / 60, color="0.6", lw=0.7, ls=":")


def bag_histories(result):
    """The paper's five time histories for every bag (height, ascent velocity, pitch angle,
    pitch rate, net flow), against time in minutes."""
    ds = result.dataset
    fig, axes = new_figure(5, 1, figsize=(8.0, 10.0), sharex=True)
    t = ds.time.values / 60
    for ax, (name, scale, label) in zip(axes, _PANELS):
        for k, b in enumerate(ds.bag.values):
            ls = "-" if ds.bag_kind.values[k] == "external" else "--"
            ax.plot(t, ds[name].values[:, k] * scale, ls, lw=1.0, label=str(b))
        ax.set_ylabel(label)
        _event_lines(ax, result)
    axes[0].legend(ncol=4, loc="upper left")
    axes[-1].set_xlabel("time [min]")
    axes[0].set_title(f"Bag histories, {result.control} control (dotted: separation, breakout)")
    return fig


def hull_motion(result):
    """Hull heave and pitch against time."""
    ds = result.dataset
    fig, (a1, a2) = new_figure(2, 1, figsize=(8.0, 5.0), sharex=True)
    t = ds.time.values / 60
    a1.plot(t, ds.heave.values)
    a1.set_ylabel("heave [m]")
    a2.plot(t, np.degrees(ds.pitch.values))
    a2.set_ylabel("pitch [deg, bow up]")
    a2.set_xlabel("time [min]")
    for ax in (a1, a2):
        _event_lines(ax, result)
    a1.set_title(f"Hull heave and pitch, {result.control} control")
    return fig


def moment_map(result):
    """Bending-moment envelope along the hull and a time-x map of the bending moment."""
    ds = result.dataset
    fig, (a1, a2) = new_figure(1, 2, figsize=(10.0, 4.2))
    x = ds.x.values
    a1.fill_between(x, ds.moment_min.values / 1e6, ds.moment_max.values / 1e6, alpha=0.3,
                    label="envelope")
    a1.plot(x, ds.moment_max.values / 1e6, lw=1)
    a1.plot(x, ds.moment_min.values / 1e6, lw=1)
    a1.set_xlabel("x from the aft end [m]")
    a1.set_ylabel("bending moment [MN m, sagging +]")
    a1.set_title("Bending-moment envelope")
    M = ds.bending_moment.values / 1e6
    lim = float(np.abs(M).max()) or 1.0
    mesh = a2.pcolormesh(x, ds.time_strength.values / 60, M, cmap="RdBu_r", vmin=-lim, vmax=lim,
                         shading="nearest")
    fig.colorbar(mesh, ax=a2, label="MN m")
    a2.set_xlabel("x from the aft end [m]")
    a2.set_ylabel("time [min]")
    a2.set_title(f"Bending moment in time, {result.control} control")
    return fig


def compare(results):
    """Several control modes on one figure: mean height, hull pitch, fastest bag velocity,
    and the bending-moment envelopes."""
    fig, axes = new_figure(2, 2, figsize=(10.0, 6.5))
    (a1, a2), (a3, a4) = axes
    for r in results:
        ds = r.dataset
        t = ds.time.values / 60
        a1.plot(t, ds.heave.values, label=r.control)
        a2.plot(t, np.degrees(ds.pitch.values), label=r.control)
        a3.plot(t, np.abs(ds.ascent_velocity.values).max(axis=1), label=r.control)
        if "x" in ds.coords:
            a4.plot(ds.x.values, np.maximum(np.abs(ds.moment_max.values),
                                            np.abs(ds.moment_min.values)) / 1e6, label=r.control)
    a1.set_ylabel("heave [m]")
    a2.set_ylabel("pitch [deg]")
    a3.set_ylabel("fastest bag point [m/s]")
    a4.set_ylabel("|bending moment| envelope [MN m]")
    for ax in (a1, a2, a3):
        ax.set_xlabel("time [min]")
    a4.set_xlabel("x from the aft end [m]")
    a1.legend()
    a1.set_title("Control modes compared")
    return fig
