"""Figures of a fuzzy controller: membership functions, control surface (3-D and contour),
and a one-input map. Each function takes computed data and returns a figure (nothing shown).
"""

from __future__ import annotations

import numpy as np

from flexlift.fuzzy.system import FIS
from flexlift.output.plots._style import new_figure


def plot_memberships(fis: FIS, samples: int = 401):
    """The membership functions of every input and output, one panel per variable (a Sugeno
    system's outputs are functions of the inputs, not sets: not drawn)."""
    outputs = [] if fis.kind == "sugeno" else list(fis.outputs)
    variables = [*fis.inputs, *outputs]
    fig, axes = new_figure(len(variables), 1, figsize=(8.0, 1.2 + 1.7 * len(variables)))
    axes = np.atleast_1d(axes)
    for k, (ax, var) in enumerate(zip(axes, variables)):
        x = np.linspace(*var.range, samples)
        for j, m in enumerate(var.mfs):
            y = m(x)
            ax.plot(x, y, lw=1.5, color=f"C{j % 10}")
            i = int(np.argmax(y))
            ax.text(x[i], min(y[i], 1.0) + 0.04, m.name, ha="center", va="bottom", fontsize=8,
                    color=f"C{j % 10}")
        ax.axhline(0.5, color="0.6", lw=0.7, ls=":")
        ax.set_ylim(-0.02, 1.22)
        ax.set_xlim(*var.range)
        j = k - len(fis.inputs)
        role = f"input {k + 1}" if j < 0 else "output" if len(outputs) == 1 else f"output {j + 1}"
        ax.set_ylabel(f"{var.name}\n({role})")
    axes[-1].set_xlabel("normalised value")
    fig.suptitle(f"Membership functions of {fis.name!r} (dotted: membership 0.5)")
    return fig


def plot_surface_3d(x0, x1, u, labels=("e", "edot", "u"), title="Control surface"):
    """The control surface u(x0, x1) as a 3-D surface; ``u[i, j]`` at (x0[i], x1[j])."""
    fig, _ = new_figure(figsize=(7.0, 5.5))
    fig.clear()
    ax = fig.add_subplot(projection="3d")
    X0, X1 = np.meshgrid(x0, x1, indexing="ij")
    ax.plot_surface(X0, X1, u, cmap="coolwarm", linewidth=0, antialiased=True,
                    rstride=1, cstride=1)
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_zlabel(labels[2])
    ax.view_init(elev=28, azim=-130)
    ax.set_title(title)
    return fig


def plot_surface_contour(x0, x1, u, labels=("e", "edot", "u"), title="Control surface",
                         centres=None):
    """The control surface as filled contours, with the rule grid (set centres) if given."""
    fig, ax = new_figure(figsize=(6.5, 5.4), margins={"top": 0.6, "right": 0.3})
    X0, X1 = np.meshgrid(x0, x1, indexing="ij")
    levels = np.linspace(min(-1.0, u.min()), max(1.0, u.max()), 21)
    cs = ax.contourf(X0, X1, u, levels=levels, cmap="coolwarm")
    ax.contour(X0, X1, u, levels=[0.0], colors="k", linewidths=1.0)
    fig.colorbar(cs, ax=ax, label=labels[2])
    if centres is not None:
        c0, c1 = centres
        g0, g1 = np.meshgrid(c0, c1, indexing="ij")
        ax.plot(g0.ravel(), g1.ravel(), ".", color="0.2", ms=3)
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_aspect("equal")
    ax.set_title(title + "\n(black: u = 0; dots: rule centres)", pad=8)
    return fig


def plot_map(x, v, xlabel="d", ylabel="fill fraction", title="SIFSMC fill map"):
    """A one-input map v(x)."""
    fig, ax = new_figure(figsize=(6.0, 3.6))
    ax.plot(x, v, lw=1.8)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    return fig
