"""Figures of the reduction stage: modal gains, Bode overlay, step and impulse overlays.

Each function takes computed data and returns a matplotlib figure (nothing is shown).
"""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import MultipleLocator

from flexlift.dynamics.statespace import (
    ModalStateSpace,
    frequency_response,
    impulse_response,
    step_response,
)
from flexlift.output.modenames import labels_of_numbers
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
    """Per-mode gains [m/N]: by mode (heave, pitch, flexible modes 1, 2, ...), against
    frequency, and sorted.

    gains : (m,) from :func:`flexlift.dynamics.statespace.mode_gains`; omega_lo [rad/s]
    """
    fig, ax = new_figure(1, 3, figsize=(11.0, 3.8))
    rigid = sys.rigid
    labels = np.array(labels_of_numbers(sys.mode_numbers, sys.n_rigid))
    pos = np.arange(1, labels.size + 1)
    g = np.where(gains > 0, gains, np.nan)
    colors = np.where(rigid, "C3", "C0")
    step = max(1, labels.size // 24)
    ax[0].bar(pos, g, color=colors)
    turn = 90 if labels.size > 12 else 0  # upright numbers would run into each other
    ax[0].set_xticks(pos[::step], [_short(s) for s in labels[::step]], fontsize=6.5,
                     rotation=turn)
    ax[0].set(yscale="log", xlabel="mode (h, p: heave, pitch; then flexible 1, 2, ...)",
              ylabel="gain [m/N]", title="gain by mode")
    f = sys.omega / (2 * np.pi)
    f_plot = np.where(rigid, omega_lo / (2 * np.pi), f)
    ax[1].scatter(f_plot[~rigid], g[~rigid], color="C0", s=14, label="flexible: dc gain")
    ax[1].scatter(f_plot[rigid], g[rigid], color="C3", marker="s", s=14,
                  label=f"rigid: |G_i| at ω_lo = {omega_lo / (2 * np.pi):.2f} Hz")
    ax[1].set(xscale="log", yscale="log", xlabel="frequency [Hz] (rigid at ω_lo)",
              ylabel="gain [m/N]", title="gain against frequency")
    ax[1].legend(loc="upper right", fontsize=7.5)  # high gains sit at low frequencies
    order = np.argsort(-np.nan_to_num(g, nan=0.0), kind="stable")
    ax[2].bar(pos, g[order], color=colors[order])
    ax[2].set_xticks(pos[::step], [_short(s) for s in labels[order][::step]], fontsize=6.5,
                     rotation=turn)
    ax[2].set(yscale="log", xlabel="mode, largest gain first", ylabel="gain [m/N]",
              title="sorted gains")
    if title:
        fig.suptitle(title)
    return fig


def _short(label: str) -> str:
    return {"heave": "h", "pitch": "p"}.get(label, label)


#: a jump this close to 180 degrees in one frequency step is a sign change of a real response
_HALF_TURN_TOL = 0.05  # [rad]


def bode_phase(response: np.ndarray) -> np.ndarray:
    """Unwrapped phase [deg] of a frequency ``response`` G sampled on an increasing grid.

    :func:`numpy.unwrap` removes the 360-degree jumps; what it cannot decide is a jump of
    exactly 180 degrees, where an undamped response (a reduced model's rigid part plus its
    mdc feedthrough) changes sign through a zero or a pole. Such a half turn is taken as a
    lightly damped pair would take it (minimum phase): up through a zero (|G| at a minimum),
    down through a pole. The curve then starts in (-270, 90].
    """
    G = response
    ph = np.unwrap(np.angle(G))
    d = np.diff(ph)
    half = np.flatnonzero(np.abs(np.abs(d) - np.pi) < _HALF_TURN_TOL)
    if half.size:
        mag = np.abs(G)
        for i in half:
            # a dip between the two samples is a zero, a peak a pole
            outer = min(mag[max(i - 1, 0)], mag[min(i + 2, mag.size - 1)])
            d[i] = np.pi if min(mag[i], mag[i + 1]) <= outer else -np.pi
        ph = np.concatenate([ph[:1], ph[0] + np.cumsum(d)])
    deg = np.degrees(ph)
    return deg - 360.0 * np.round((deg[0] + 90.0) / 360.0)


def plot_bode(models: dict[str, ModalStateSpace], omega: np.ndarray, title: str = ""):
    """Bode magnitude and unwrapped phase (:func:`bode_phase`) of the full and reduced SISO
    models over ``omega`` [rad/s]."""
    fig, ax = new_figure(2, 1, figsize=(8.0, 6.0), sharex=True)
    f = omega / (2 * np.pi)
    for name, s in models.items():
        G = frequency_response(s, omega)[0, 0]
        ax[0].loglog(f, np.abs(G), **_style(name))
        ax[1].semilogx(f, bode_phase(G), **_style(name))
    ax[0].set(ylabel="|G| [m/N]", title=title or "frequency response, full and reduced")
    ax[1].set(xlabel="frequency [Hz]", ylabel="phase [deg], unwrapped")
    ax[1].yaxis.set_major_locator(MultipleLocator(45 if _span(ax[1]) <= 270 else 90))
    ax[1].legend(loc="upper left", fontsize=7.5)  # the rigid-body band: one phase there
    return fig


def _span(ax) -> float:
    lo, hi = ax.get_ylim()
    return hi - lo


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
