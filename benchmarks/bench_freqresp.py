"""Frequency response of a 400-mode (800-state) modal model at 10,000 frequencies:
flexlift's closed form against ``control.frequency_response`` on the same system.

python-control 0.10.2 without slycot evaluates C (jωI − A)⁻¹ B + D with one dense 800×800
solve per frequency in a Python loop; its cost per frequency does not depend on the frequency,
so it is timed on an evenly spread subset of the 10,000 frequencies (``peer_frequencies``)
and scaled to the full set (``control_s_extrapolated``); the values are checked against ours
on that subset. Times are the best of ``repeats`` runs.
"""

from __future__ import annotations

import time
import tracemalloc

import numpy as np

ELEMENTS = 199  # 200 nodes, 400 DOFs, 400 modes (2 rigid)


def _best(fn, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def _peak_bytes(fn) -> int:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def run(quick: bool = False) -> dict:
    import control

    from flexlift.dynamics.statespace import frequency_response, modal_state_space, to_control
    from flexlift.structure.hull import Hull
    from flexlift.structure.modes import compute_modes

    n_freq = 10_000
    n_peer = 40 if quick else 400
    repeats = 3 if quick else 7
    hull = Hull.uniform(78.02, 3.0e12, 3.2e6 / 78.02, ELEMENTS)
    modes = compute_modes(hull)
    siso = modal_state_space(modes, ["f_node_50"], ["w_node_50"], 0.02)
    mimo = modal_state_space(modes, [f"f_node_{k}" for k in (10, 50, 100, 150)],
                             [f"w_node_{k}" for k in (10, 50, 100, 150)], 0.02)
    w = np.geomspace(0.1 * modes.omega[2], 1.2 * modes.omega.max(), n_freq)
    ours_s = _best(lambda: frequency_response(siso, w), repeats)
    ours_mimo_s = _best(lambda: frequency_response(mimo, w), repeats)
    ours_peak = _peak_bytes(lambda: frequency_response(siso, w))

    sys = to_control(siso)
    sub = w[np.linspace(0, n_freq - 1, n_peer).astype(int)]
    t0 = time.perf_counter()
    ref = control.frequency_response(sys, sub, squeeze=False).complex
    peer_sub_s = time.perf_counter() - t0
    peer_peak = _peak_bytes(lambda: control.frequency_response(sys, sub[:20], squeeze=False))
    peer_s = peer_sub_s * n_freq / n_peer
    G = frequency_response(siso, sub)
    rel = float(np.max(np.abs(G - ref)) / np.max(np.abs(ref)))
    return {
        "modes": int(siso.n_modes),
        "states": int(siso.n_states),
        "frequencies": n_freq,
        "flexlift_siso_s": round(ours_s, 5),
        "flexlift_mimo_4x4_s": round(ours_mimo_s, 5),
        "flexlift_peak_bytes": int(ours_peak),
        "control_version": control.__version__,
        "peer_frequencies": n_peer,
        "control_subset_s": round(peer_sub_s, 4),
        "control_s_per_frequency": round(peer_sub_s / n_peer, 6),
        "control_s_extrapolated": round(peer_s, 2),
        "control_peak_bytes_20_freq": int(peer_peak),
        "ratio_control_over_flexlift": round(peer_s / ours_s, 1),
        "max_rel_difference": rel,
    }


if __name__ == "__main__":  # pragma: no cover
    import json

    print(json.dumps(run(quick=True), indent=2))
