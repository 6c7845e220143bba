"""Figures of the reduction stage: modal gains, Bode overlay, step and impulse overlays.

Each function takes computed data and returns a matplotlib figure (nothing is shown).
"""

from __future__ import annotations

import numpy as np

from flexlift.dynamics.statespace import (
    ModalStateSpace,
    frequency_response,
    impulse_response,
    step_response,
)
from flexlift.output.plots._style import new_figure

_STYLE = {
    "full": dict(color="k", lw=2.2, alpha=0.5, label="full"),
    "unsorted_del": dict(color="C0", ls="--", label="unsorted del"),
    "unsorted_mdc": dict(color="C1", ls="-", label="unsorted mdc"),
    "sorted_del": dict(color="C2", ls=":", label="sorted del"),
    "sorted_mdc": dict(color="C3", ls="-.", label="sorted mdc"),
}


def _style(name: str) -> dict:
    return dict(_STYLE.get(name, {"label": name}))


def plot_gains(sys: ModalStateSpace, gains: np.ndarray, omega_lo: float, title: str = ""):
    """Per-mode gains [m/N]: against mode number, against frequency, and sorted.

    gains : (m,) from :func:`flexlift.dynamics.statespace.mode_gains`; omega_lo [rad/s]
    """
    fig, ax = new_figure(1, 3, figsize=(11.0, 3.8))
    rigid = sys.rigid
    num = sys.mode_numbers
    g = np.where(gains > 0, gains, np.nan)
    colors = np.where(rigid, "C3", "C0")
    ax[0].bar(num, g, color=colors)
    ax[0].set(yscale="log", xlabel="mode number", ylabel="gain [m/N]",
              title="gain by mode (unsorted)")
    f = sys.omega / (2 * np.pi)
    f_plot = np.where(rigid, omega_lo / (2 * np.pi), f)
    ax[1].scatter(f_plot[~rigid], g[~rigid], color="C0", label="flexible: dc gain")
    ax[1].scatter(f_plot[rigid], g[rigid], color="C3", marker="s",
                  label=f"rigid: |G_i| at ω_lo = {omega_lo / (2 * np.pi):.2f} Hz")
    ax[1].set(xscale="log", yscale="log", xlabel="frequency [Hz] (rigid at ω_lo)",
              ylabel="gain [m/N]", title="gain against frequency")
    ax[1].legend()
    order = np.argsort(-np.nan_to_num(g, nan=0.0), kind="stable")
    ax[2].bar(np.arange(1, order.size + 1), g[order], color=colors[order])
    ax[2].set_xticks(np.arange(1, order.size + 1))
    ax[2].set_xticklabels([str(n) for n in num[order]], fontsize=6, rotation=90)
    ax[2].set(yscale="log", xlabel="mode number, largest gain first", ylabel="gain [m/N]",
              title="sorted gains")
    if title:
        fig.suptitle(title)
    return fig


def plot_bode(models: dict[str, ModalStateSpace], omega: np.ndarray, title: str = ""):
    """Bode magnitude and phase of the full and reduced SISO models over ``omega`` [rad/s]."""
    fig, ax = new_figure(2, 1, figsize=(8.0, 6.0), sharex=True)
    f = omega / (2 * np.pi)
    for name, s in models.items():
        G = frequency_response(s, omega)[0, 0]
        ax[0].loglog(f, np.abs(G), **_style(name))
        ph = np.degrees(np.unwrap(np.angle(G)))
        ph -= 360.0 * np.round((ph[0] + 90.0) / 360.0)  # start in (-270, 90] for every curve
        ax[1].semilogx(f, ph, **_style(name))
    ax[0].set(ylabel="|G| [m/N]", title=title or "frequency response, full and reduced")
    ax[1].set(xlabel="frequency [Hz]", ylabel="phase [deg]")
    ax[0].legend(ncols=3)
    return fig


def plot_time(models: dict[str, ModalStateSpace], t: np.ndarray, title: str = ""):
    """Step (1 N) and impulse (1 N s) responses of the SISO models over times ``t`` [s].
    The rigid modes make the step response grow as t²/2 and the impulse response as t, so the
    responses are shown with their rigid-body part removed as well (right column)."""
    fig, ax = new_figure(2, 2, figsize=(10.0, 6.0), sharex=True)
    full = models["full"]
    rigid_only = full.with_modes(np.flatnonzero(full.rigid))
    ys_r = step_response(rigid_only, t)[0, 0]
    yi_r = impulse_response(rigid_only, t)[0, 0]
    for name, s in models.items():
        ys = step_response(s, t)[0, 0]
        yi = impulse_response(s, t)[0, 0]
        ax[0, 0].plot(t, ys, **_style(name))
        ax[1, 0].plot(t, yi, **_style(name))
        ax[0, 1].plot(t, ys - ys_r, **_style(name))
        ax[1, 1].plot(t, yi - yi_r, **_style(name))
    ax[0, 0].set(ylabel="step response [m/N]", title="step (1 N)")
    ax[1, 0].set(ylabel="impulse response [m/(N s)]", xlabel="time [s]", title="impulse (1 N s)")
    ax[0, 1].set(title="step, rigid-body part removed")
    ax[1, 1].set(xlabel="time [s]", title="impulse, rigid-body part removed")
    ax[0, 0].legend()
    if title:
        fig.suptitle(title)
    return fig
