"""The fuzzy engine per point: Mamdani against scikit-fuzzy, Sugeno against the plain reference.

Mamdani: the supervisory FIS (2 inputs, 49 rules) against scikit-fuzzy's
ControlSystemSimulation: same sets, rules, min/max, centroid, output grid of 101 points.
scikit-fuzzy is timed on distinct random points (its simulation caches repeated inputs); its
batch cost per point is its single-point cost (it loops over points). Ours: single-point
calls, a batch of 10,000, and the 81 x 81 interpolated surface.

Sugeno: MATLAB's shipped invkine1.fis (2 inputs, 49 rules, gbellmf sets, linear outputs, from
the test corpus). scikit-fuzzy has no Sugeno inference, so the peer is the plain reference
evaluator of the tests (tests/fis_reference.py: scalar Python, one point at a time), the
slow, obvious implementation of the same semantics.
"""

from __future__ import annotations

import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

from flexlift.fuzzy.fis import to_skfuzzy


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

    from flexlift.fuzzy.rulebase import supervisor_fis

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

    sugeno = _sugeno(quick, rng)
    # no like-for-like peer exists for Sugeno; for scale only: ours against scikit-fuzzy's
    # per-point cost on the (Mamdani) supervisor above
    sugeno["sugeno_batch_vs_skfuzzy_mamdani_per_point"] = t_sk / sugeno[
        "sugeno_flexlift_batch_s_per_point"]

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
        **sugeno,
    }


def _sugeno(quick: bool, rng) -> dict:
    root = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root / "tests"))
    from fis_reference import evaluate

    from flexlift.fuzzy.fis import read_fis

    fis = read_fis(root / "tests" / "data" / "fis" / "matlab" / "invkine1.fis")
    lo = np.array([v.range[0] for v in fis.inputs])
    hi = np.array([v.range[1] for v in fis.inputs])
    ref_pts = rng.uniform(lo, hi, (50 if quick else 300, 2))
    t0 = time.perf_counter()
    ref = np.array([evaluate(fis, p)[0] for p in ref_pts])
    t_ref = (time.perf_counter() - t0) / len(ref_pts)
    t_single = _per_call(fis, rng.uniform(lo, hi, (300 if quick else 2000, 2)))
    batch = rng.uniform(lo, hi, (10_000, 2))
    fis(batch)
    t_batch = min(_timed(lambda: fis(batch)) for _ in range(3 if quick else 7)) / len(batch)
    return {
        "sugeno_system": "invkine1.fis (MATLAB example: 2 inputs, 49 rules, gbellmf, linear)",
        "sugeno_peer": "tests/fis_reference.py, plain Python (scikit-fuzzy has no Sugeno)",
        "sugeno_reference_s_per_point": t_ref,
        "sugeno_flexlift_single_s": t_single,
        "sugeno_flexlift_batch_s_per_point": t_batch,
        "sugeno_ratio_single": t_ref / t_single,
        "sugeno_ratio_batch": t_ref / t_batch,
        "sugeno_max_abs_diff_vs_reference": float(np.max(np.abs(fis(ref_pts) - ref))),
    }


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    import json

    print(json.dumps(run(), indent=2))
