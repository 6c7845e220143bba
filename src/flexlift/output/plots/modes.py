"""Figures of the modal analysis: mode shapes, frequency against mode number, convergence.

Each function takes computed data and returns a matplotlib figure (nothing is shown);
save it with :func:`flexlift.output.plots._style.save`.
"""

from __future__ import annotations

import numpy as np
from matplotlib.ticker import MaxNLocator, NullFormatter, ScalarFormatter

from flexlift.output.modenames import mode_title
from flexlift.output.plots._style import new_figure
from flexlift.structure.convergence import Convergence, is_uniform
from flexlift.structure.modes import Modes, analytic_free_free_hz, mode_nodes, zero_crossings

_SAMPLES_PER_ELEMENT = 40
_MAX_SAMPLES = 4001


def plot_mode_shapes(modes: Modes, n_flex: int = 5, highlight: int | None = None):
    """Unit-peak displacement of flexible modes 1..``n_flex`` along the hull, with the beam
    nodes nearest each mode's zero crossings ("nodes of the mode") marked; the panel of
    flexible mode ``highlight`` (the lift plan's layout mode, if any) is drawn bold."""
    hull = modes.hull
    n_flex = max(0, min(n_flex, modes.n_modes - modes.n_rigid))
    n_x = min(hull.n_elements * _SAMPLES_PER_ELEMENT + 1, _MAX_SAMPLES)
    x = np.linspace(0.0, hull.length, n_x)
    fig, axes = new_figure(n_flex, 1, sharex=True, figsize=(8.0, 1.5 + 1.25 * n_flex))
    axes = np.atleast_1d(axes)
    xn = hull.x_nodes
    f = modes.frequencies_hz
    for k, ax in enumerate(axes, start=1):
        col = modes.flexible_index(k)
        w = modes.shape_at(x, columns=col)[:, 0]
        peak = w[np.argmax(np.abs(w))]
        w = w / peak
        bold = k == highlight
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.plot(x, w, lw=2.4 if bold else 1.6, color=f"C{k - 1}")
        xz = zero_crossings(modes, col)
        ax.plot(xz, np.zeros_like(xz), "x", color="k", ms=5, label="zero crossing")
        nodes = mode_nodes(modes, col)
        wn = modes.shape_at(xn[nodes], columns=col)[:, 0] / peak
        ax.plot(xn[nodes], wn, "o", ms=6, mfc="white", mec="k", label="nearest beam node")
        if hull.n_elements <= 60:
            ax.plot(xn, np.zeros_like(xn), "|", color="0.3", ms=6)
        ax.set_ylim(-1.25, 1.25)
        ax.set_ylabel(f"{mode_title(col, modes.n_rigid)}\n{f[col]:.3g} Hz",
                      fontweight="bold" if bold else "normal")
        shown = ", ".join(str(n + 1) for n in nodes[:12]) + (" ..." if len(nodes) > 12 else "")
        where = "; the external bags sit here" if bold else ""
        ax.set_title(f"nodes (1-based): {shown}{where}", loc="right", fontsize=8,
                     fontweight="bold" if bold else "normal")
    axes[0].legend(loc="lower left", bbox_to_anchor=(0.0, 1.0), ncols=2, fontsize=7.5)
    fig.suptitle(
        f"Flexible modes 1 to {n_flex} of the free-free hull (dry, unit peak, "
        f"{hull.n_elements} elements; x = 0 aft)"
    )
    axes[-1].set_xlabel("x from the aft end [m]")
    return fig


def plot_frequencies(modes: Modes, wet: Modes | None = None, n_shown: int | None = None):
    """Natural frequency against flexible mode number 1..``n_shown`` (default: all computed),
    dry and (given ``wet``) wet, with the analytic uniform-beam values where the hull is
    uniform. Heave and pitch (0 Hz) are named in the corner, not drawn."""
    fig, ax = new_figure()
    nr = modes.n_rigid
    n = modes.n_modes - nr if n_shown is None else min(n_shown, modes.n_modes - nr)
    k = np.arange(1, n + 1)
    f = modes.frequencies_hz[nr:nr + n]
    ax.plot(k, f, "o-", ms=4, label=f"dry, FE {modes.hull.n_elements} elements")
    if wet is not None:
        m = min(n, wet.n_modes - wet.n_rigid)
        ax.plot(k[:m], wet.frequencies_hz[wet.n_rigid:wet.n_rigid + m], "s--", ms=4,
                color="C2", label="wet (added mass, entrained water)")
    if is_uniform(modes.hull):
        ka = min(5, n)
        ax.plot(k[:ka], analytic_free_free_hz(modes.hull, ka), "x", ms=8, mew=2, color="C3",
                label="analytic, dry (uniform free-free beam)")
    ax.set_xlabel("flexible mode")
    if n <= 25:
        ax.set_xticks(k)
    else:
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_ylabel("natural frequency [Hz]")
    ax.set_ylim(bottom=0)
    ax.text(0.98, 0.04, "heave, pitch: rigid, 0 Hz", fontsize=8, ha="right", color="0.3",
            transform=ax.transAxes)
    ax.set_title("Natural frequencies of the free-free hull, dry and wet")
    ax.legend(loc="upper left")
    return fig


def plot_convergence(conv: Convergence):
    """Relative frequency error against element count (log-log), with an h^4 guide."""
    fig, ax = new_figure()
    err = np.abs(conv.rel_error)
    n = conv.elements.astype(float)
    for j in range(err.shape[1]):
        ok = np.isfinite(err[:, j]) & (err[:, j] > 0)
        ax.loglog(n[ok], err[ok, j], "o-", ms=4,
                  label=f"flexible mode {j + 1} (slope {conv.rates[j]:.2f})")
    ok = np.isfinite(err[:, 0]) & (err[:, 0] > 0)
    if ok.any():
        n0, e0 = n[ok][0], err[ok, 0][0]
        ax.loglog(n, e0 * (n / n0) ** -4, "k--", lw=1, label="slope -4 (h^4)")
    ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xticks(n)
    ax.set_xlabel("number of elements")
    ax.set_ylabel(f"|f / f_ref - 1|   (reference: {conv.reference})")
    ax.set_title("Convergence of the flexible frequencies (Hermite cubic elements)")
    ax.legend(fontsize=7.5)
    return fig
