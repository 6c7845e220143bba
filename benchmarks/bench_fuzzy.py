"""The Mamdani engine against scikit-fuzzy's ControlSystemSimulation on the supervisory FIS.

Same sets, rules, min/max, centroid, output grid of 101 points. scikit-fuzzy is timed on
distinct random points (its simulation caches repeated inputs); its batch cost per point is
its single-point cost (it loops over points). Ours: single-point calls, a batch of 10,000,
and the 81 x 81 interpolated surface.
"""

from __future__ import annotations

import time
import tracemalloc

import numpy as np

from flexlift.fis import to_skfuzzy


def _per_call(fn, points, repeat=5):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        for p in points:
            fn(p)
        best = min(best, (time.perf_counter() - t0) / len(points))
    return best


def run(quick: bool = False) -> dict:
    import warnings

    from flexlift.rulebase import supervisor_fis

    warnings.filterwarnings("ignore", category=DeprecationWarning)
    fis = supervisor_fis()
    trapz = fis.with_options(defuzzification="centroid_trapz")
    rng = np.random.default_rng(0)
    n_sk = 5 if quick else 20
    n_batch = 10_000
    sk_pts = rng.uniform(-1, 1, (n_sk, 2))
    sim = to_skfuzzy(fis)[0]

    def sk(p):
        sim.input["e"], sim.input["edot"] = p[0], p[1]
        sim.compute()
        return sim.output["u"]

    t0 = time.perf_counter()
    sk_u = np.array([sk(p) for p in sk_pts])
    t_sk = (time.perf_counter() - t0) / n_sk

    single_pts = rng.uniform(-1, 1, (2000 if not quick else 300, 2))
    t_single = _per_call(fis, single_pts)
    batch = rng.uniform(-1, 1, (n_batch, 2))
    fis(batch)
    t_batch = min(_timed(lambda: fis(batch)) for _ in range(3 if quick else 7)) / n_batch
    tracemalloc.start()
    fis(batch)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()

    t0 = time.perf_counter()
    surf = fis.surface(grid=81)
    t_build = time.perf_counter() - t0
    t_surf_single = _per_call(surf, single_pts)
    t_surf_batch = min(_timed(lambda: surf(batch)) for _ in range(7)) / n_batch

    # same answers: skfuzzy adds the cut crossings to its grid before the trapezoid centroid,
    # so it is compared with our piecewise-linear centroid (and MATLAB's discrete one, for info)
    return {
        "skfuzzy_s_per_point": t_sk,
        "flexlift_single_s": t_single,
        "flexlift_batch_s_per_point": t_batch,
        "flexlift_batch_points": n_batch,
        "flexlift_batch_peak_bytes": int(peak),
        "surface_build_s": t_build,
        "surface_single_s": t_surf_single,
        "surface_batch_s_per_point": t_surf_batch,
        "surface_max_error": surf.max_error,
        "ratio_single": t_sk / t_single,
        "ratio_batch": t_sk / t_batch,
        "ratio_surface_single": t_sk / t_surf_single,
        "ratio_surface_batch": t_sk / t_surf_batch,
        "max_abs_diff_centroid_trapz_vs_skfuzzy": float(np.max(np.abs(trapz(sk_pts) - sk_u))),
        "max_abs_diff_matlab_centroid_vs_skfuzzy": float(np.max(np.abs(fis(sk_pts) - sk_u))),
        "skfuzzy_points_timed": n_sk,
    }


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))
