"""Model order reduction of the modal state space by truncation (docs/theory/reduction.md#del-mdc).

Keep r modes, eliminate the rest:

- ordering "unsorted": keep the r lowest-frequency modes; "sorted": keep the modes of largest
  gain (:func:`flexlift.dynamics.statespace.mode_gains`). The rigid modes are always kept (a model
  without them cannot follow the ascent), so "sorted" ranks the flexible modes for the
  remaining r − n_rigid places; at r = n_rigid both orderings give the same model.
- method "del": delete the eliminated states (plain truncation);
  "mdc" (matched dc gain): set the eliminated states' derivatives to zero and solve for them.
  With a block-diagonal A this leaves A, B, C of the kept modes unchanged and adds the
  eliminated modes' static contribution Σ c_i b_i / ω_i² to D, so the reduced model's static
  gain of the flexible part equals the full model's exactly.

The comparison follows the paper's Table 2: the gain error at ω_lo,
100 (|G_r(jω_lo)| − |G(jω_lo)|) / |G(jω_lo)| [%], and the signed error of the peak magnitude
of |G| over the band ω_lo .. highest modal frequency of the full model [%] (negative: the
reduced model is low). With the rigid modes in the model their 1/ω² response dominates at
ω_lo, so for a bag's own displacement the band's peak sits at ω_lo and the two errors agree;
a third, added measure is therefore reported: the signed magnitude error at the full model's
largest resonance peak, which shows whether a reduced model has that resonance at all.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexlift.dynamics.statespace import (
    ModalStateSpace,
    default_omega_lo,
    frequency_response,
    modal_state_space,
    mode_gains,
)
from flexlift.errors import InputError
from flexlift.structure.modes import Modes

#: the four reductions, in the order of the paper's table
METHODS = ("unsorted_del", "unsorted_mdc", "sorted_del", "sorted_mdc")

#: default number of retained modes: the two rigid modes, i.e. the 4-state model
DEFAULT_ORDER = 2


def _check_order(sys: ModalStateSpace, order: int) -> int:
    if isinstance(order, bool) or not isinstance(order, int | np.integer):
        raise InputError("order", order, "a whole number of modes to keep")
    if not sys.n_rigid <= order <= sys.n_modes:
        raise InputError(
            "order", int(order),
            f"keep {sys.n_rigid}..{sys.n_modes} modes (the {sys.n_rigid} rigid modes are "
            f"never eliminated; the model has {sys.n_modes} modes)")
    return int(order)


def kept_modes(sys: ModalStateSpace, order: int, ordering: str = "unsorted",
               omega_lo: float | None = None) -> np.ndarray:
    """0-based positions (ascending) of the ``order`` modes to keep.

    ordering : "unsorted" (lowest frequencies) or "sorted" (largest gain; for a MIMO model
        the root-sum-square over all input/output pairs)
    omega_lo : frequency at which rigid modes are ranked [rad/s] (default: 0.1 × first flexible)
    """
    order = _check_order(sys, order)
    rigid = np.flatnonzero(sys.rigid)
    flex = np.flatnonzero(~sys.rigid)
    n_flex = order - rigid.size
    if ordering == "unsorted":
        chosen = flex[np.argsort(sys.omega[flex], kind="stable")[:n_flex]]
    elif ordering == "sorted":
        if n_flex == 0:
            chosen = flex[:0]
        else:
            g = mode_gains(sys, omega_lo, output=None, input=None)[flex]
            chosen = flex[np.lexsort((sys.omega[flex], -g))[:n_flex]]
    else:
        raise InputError("ordering", ordering, "use 'unsorted' or 'sorted'")
    return np.sort(np.concatenate([rigid, chosen]))


def truncate(sys: ModalStateSpace, keep, method: str = "del") -> ModalStateSpace:
    """Keep the modes at 0-based positions ``keep``; method "del" or "mdc" (module docstring).
    Eliminating a rigid mode is refused (it has no static equilibrium)."""
    keep = np.unique(np.asarray(keep, int))
    if keep.size and (keep.min() < 0 or keep.max() >= sys.n_modes):
        raise InputError("keep", keep.tolist(), f"mode positions are 0..{sys.n_modes - 1}")
    elim = np.setdiff1d(np.arange(sys.n_modes), keep)
    if np.any(sys.rigid[elim]):
        raise InputError("keep", keep.tolist(),
                         f"the rigid modes {np.flatnonzero(sys.rigid).tolist()} must be kept")
    if method == "del":
        return sys.with_modes(keep)
    if method == "mdc":
        w2 = sys.omega[elim] ** 2
        D = sys.D + np.einsum("om,mi->oi", sys.c_disp[:, elim] / w2, sys.b[elim])
        return sys.with_modes(keep, D)
    raise InputError("method", method, "use 'del' or 'mdc'")


def reduce_model(sys: ModalStateSpace, order: int = DEFAULT_ORDER, ordering: str = "unsorted",
                 method: str = "mdc", omega_lo: float | None = None) -> ModalStateSpace:
    """``sys`` reduced to ``order`` modes (2·order states) by one of the four reductions."""
    return truncate(sys, kept_modes(sys, order, ordering, omega_lo), method)


def reduce_all(sys: ModalStateSpace, order: int = DEFAULT_ORDER,
               omega_lo: float | None = None) -> dict[str, ModalStateSpace]:
    """{"full": sys, "unsorted_del": ..., ..., "sorted_mdc": ...}."""
    out = {"full": sys}
    for name in METHODS:
        ordering, method = name.split("_")
        out[name] = reduce_model(sys, order, ordering, method, omega_lo)
    return out


def paper_bag_model(modes: Modes, node: int, zeta: float = 0.02) -> ModalStateSpace:
    """The paper's 4-state plant of one bag: vertical force at 0-based ``node`` [N] to the
    displacement there [m]; the two rigid modes kept, every flexible mode folded into D by
    mdc (unsorted, order 2). zeta : flexible modal damping [-]."""
    n_nodes = modes.hull.n_nodes
    if isinstance(node, bool) or not isinstance(node, int | np.integer) or not 0 <= node < n_nodes:
        raise InputError("node", node, f"0-based node index 0..{n_nodes - 1}")
    k = int(node) + 1
    full = modal_state_space(modes, [f"f_node_{k}"], [f"w_node_{k}"], zeta)
    return reduce_model(full, 2, "unsorted", "mdc")


# ---------------------------------------------------------------------- comparison
@dataclass(frozen=True)
class MethodError:
    """Accuracy of one reduced model against the full one.

    states : number of states; modes : 1-based numbers of the kept modes
    dc_error_pct : gain error at ω_lo [%]; peak_error_pct : signed error of the peak
    magnitude over the band [%]
    resonance_error_pct : signed magnitude error at the full model's largest resonance
        (None when the full model shows no resonance peak in the band) [%]
    """

    name: str
    states: int
    modes: tuple[int, ...]
    dc_error_pct: float
    peak_error_pct: float
    resonance_error_pct: float | None = None


@dataclass(frozen=True)
class Comparison:
    """The comparison table of the reductions of one model.

    omega_lo : frequency of the gain error [rad/s]; band : (ω_lo, highest modal ω) [rad/s]
    rows : one :class:`MethodError` per reduced model, in :data:`METHODS` order
    most_accurate : name of the row with the smallest max(|dc error|, |peak error|), the
        paper's two measures (differences below 1e-6 % are ties: the first in
        :data:`METHODS` order wins)
    resonance_omega : frequency of the full model's largest resonance peak in the band
        (None if it has none) [rad/s]
    """

    omega_lo: float
    band: tuple[float, float]
    rows: tuple[MethodError, ...]
    most_accurate: str
    resonance_omega: float | None = None

    def row(self, name: str) -> MethodError:
        for r in self.rows:
            if r.name == name:
                return r
        raise InputError("method", name, f"known methods are {', '.join(METHODS)}")


def band_grid(full: ModalStateSpace, omega_lo: float, n: int = 4000) -> np.ndarray:
    """Frequencies [rad/s] from ω_lo to the highest modal frequency: a log grid plus every
    mode's resonance ω_i √(1 − 2ζ_i²) inside the band, so that no peak is missed."""
    w_hi = float(full.omega.max())
    if not 0 < omega_lo < w_hi:
        raise InputError("omega_lo", omega_lo, f"must lie in 0..{w_hi:.4g} rad/s")
    res = full.omega * np.sqrt(np.clip(1 - 2 * full.zeta**2, 0, None))
    grid = np.concatenate([np.geomspace(omega_lo, w_hi, n), res, full.omega])
    return np.unique(grid[(grid >= omega_lo) & (grid <= w_hi)])


def compare(models: dict[str, ModalStateSpace], omega_lo: float | None = None, output=0,
            input=0, n_freq: int = 4000) -> Comparison:
    """Errors of each reduced model in ``models`` (as from :func:`reduce_all`; must contain
    "full") for one input/output pair (names or positions). omega_lo [rad/s] default 0.1 ×
    the first flexible frequency of the full model."""
    full = models["full"]
    w_lo = default_omega_lo(full) if omega_lo is None else float(omega_lo)
    grid = band_grid(full, w_lo, n_freq)
    w = np.concatenate([[w_lo], grid])

    def mag(s: ModalStateSpace) -> np.ndarray:
        oi = s.index(output) if isinstance(output, str) else int(output)
        ii = s.index(input, "input") if isinstance(input, str) else int(input)
        return np.abs(frequency_response(s, w)[oi, ii])

    g = mag(full)
    gb = g[1:]
    peaks = np.flatnonzero((gb[1:-1] > gb[:-2]) & (gb[1:-1] >= gb[2:])) + 1
    k_res = int(peaks[np.argmax(gb[peaks])]) + 1 if peaks.size else None
    rows = []
    for name, s in models.items():
        if name == "full":
            continue
        gr = mag(s)
        rows.append(MethodError(
            name, s.n_states, tuple(int(k) for k in s.mode_numbers),
            float(100 * (gr[0] - g[0]) / g[0]),
            float(100 * (gr[1:].max() - g[1:].max()) / g[1:].max()),
            None if k_res is None else float(100 * (gr[k_res] - g[k_res]) / g[k_res]),
        ))
    # differences below 1e-6 % are ties, resolved in METHODS order
    best = min(rows, key=lambda r: round(max(abs(r.dc_error_pct), abs(r.peak_error_pct)), 6))
    return Comparison(w_lo, (float(grid[0]), float(grid[-1])), tuple(rows), best.name,
                      None if k_res is None else float(w[k_res]))
