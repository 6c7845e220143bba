"""Convergence study: the first flexible frequencies against the number of elements.

For a uniform beam (constant EI and mass per length, no point masses) the reference is the
analytic free-free solution, f_n = (beta_n L)^2 / (2 pi L^2) sqrt(EI / m). For any other hull
the reference is the same hull on a much finer mesh (64 times the finest studied), and the
meshes studied are multiples of the hull's own element count, so that the piecewise-constant
properties and point masses are represented exactly on every mesh.

Hermite cubic elements with consistent mass converge as h^4 in frequency (the eigenvalue
error of a 4th-order problem with cubic elements is O(h^(2(p+1-m))) = O(h^4), p = 3, m = 2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexlift.errors import InputError
from flexlift.structure.hull import Hull
from flexlift.structure.modes import analytic_free_free_hz, compute_modes

#: element counts studied for a uniform beam (the paper's 11 among them)
DEFAULT_COUNTS = (3, 4, 6, 8, 11, 16, 24, 32, 48, 64)
#: errors below this are round-off, not discretisation, and are left out of the rate fit
ERROR_FLOOR = 1e-11


@dataclass(frozen=True)
class Convergence:
    """Result of :func:`convergence_study`.

    elements : ndarray (k,) — element counts studied [-]
    frequencies_hz : ndarray (k, n) — first n flexible frequencies per mesh [Hz]
        (NaN where a mesh has fewer flexible modes)
    reference_hz : ndarray (n,) — reference frequencies [Hz]
    reference : str — "analytic" or "N elements" (the fine mesh used as reference)
    rates : ndarray (n,) — fitted slope p of |error| ~ elements^p for each mode [-]
        (about -4 for Hermite cubics)
    """

    elements: np.ndarray
    frequencies_hz: np.ndarray
    reference_hz: np.ndarray
    reference: str
    rates: np.ndarray

    @property
    def rel_error(self) -> np.ndarray:
        """Relative error f / f_ref - 1, shape (k, n) [-]."""
        return self.frequencies_hz / self.reference_hz[None, :] - 1.0

    def to_dict(self) -> dict:
        """A JSON-ready summary (NaN as None)."""

        def clean(a):
            return [None if not np.isfinite(v) else float(v) for v in np.ravel(a)]

        return {
            "elements": [int(e) for e in self.elements],
            "reference": self.reference,
            "reference_hz": clean(self.reference_hz),
            "frequencies_hz": [clean(row) for row in self.frequencies_hz],
            "rel_error": [clean(row) for row in self.rel_error],
            "rates": clean(self.rates),
        }


def is_uniform(hull: Hull) -> bool:
    """True for constant EI and mass per length and no point masses (analytic case)."""
    return bool(
        np.ptp(hull.EI) <= 1e-12 * hull.EI.max()
        and np.ptp(hull.mass_per_length) <= 1e-12 * hull.mass_per_length.max()
        and not np.any(hull.point_masses)
    )


def convergence_rate(elements: np.ndarray, errors: np.ndarray, tail: int = 4) -> float:
    """Least-squares slope of log|error| against log(elements) over the ``tail`` finest
    meshes whose error is above round-off (:data:`ERROR_FLOOR`); NaN if fewer than two."""
    e = np.abs(np.asarray(errors, dtype=float))
    n = np.asarray(elements, dtype=float)
    ok = np.isfinite(e) & (e > ERROR_FLOOR)
    n, e = n[ok][-tail:], e[ok][-tail:]
    if n.size < 2:
        return float("nan")
    return float(np.polyfit(np.log(n), np.log(e), 1)[0])


def convergence_study(
    hull: Hull, element_counts: tuple[int, ...] | None = None, n_flex: int = 5
) -> Convergence:
    """First ``n_flex`` flexible frequencies of ``hull`` re-meshed with each element count.

    hull : the structure (uniform: analytic reference; otherwise a fine-mesh reference)
    element_counts : meshes to study [-] (default :data:`DEFAULT_COUNTS` for a uniform hull,
        1, 2, 4, 8, 16 times the hull's element count otherwise)
    n_flex : number of flexible modes to follow, 1..5 [-]
    """
    if not 1 <= int(n_flex) <= 5:
        raise InputError("n_flex", n_flex, "follow 1..5 flexible modes")
    n_flex = int(n_flex)
    uniform = is_uniform(hull)
    if element_counts is None:
        base = hull.n_elements
        counts = DEFAULT_COUNTS if uniform else tuple(base * k for k in (1, 2, 4, 8, 16))
    else:
        counts = tuple(int(c) for c in element_counts)
    if not counts or min(counts) < 1:
        raise InputError("element_counts", list(counts), "give element counts >= 1")
    counts = np.array(sorted(set(counts)))
    freqs = np.full((counts.size, n_flex), np.nan)
    for i, n in enumerate(counts):
        k = min(n_flex, 2 * int(n))  # a mesh of n elements has 2n flexible modes
        modes = compute_modes(hull.refined(int(n)), n_modes=k + 2)
        freqs[i, :k] = modes.frequencies_hz[2 : 2 + k]
    if uniform:
        ref = analytic_free_free_hz(hull, n_flex)
        label = "analytic"
    else:
        fine = int(counts[-1]) * 64
        ref = compute_modes(hull.refined(fine), n_modes=n_flex + 2).frequencies_hz[2:]
        label = f"{fine} elements"
    err = freqs / ref[None, :] - 1.0
    rates = np.array([convergence_rate(counts, err[:, j]) for j in range(n_flex)])
    return Convergence(counts, freqs, ref, label, rates)
