"""A sweep case's Python work outside the loop made cheaper without changing a number
(issue 28, "a cheaper case"): each shortcut against the code it replaced, bit for bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from flexlift.control.profile import _passes, valve_profile
from flexlift.loads.strength import shear_moment

TRAWLER = Path(__file__).parent / "data" / "trawler.yaml"
BAGS = Path(__file__).resolve().parents[1] / "benchmarks" / "bags_tanker.yaml"


def _passes_before(cap: np.ndarray, accel: float, dz: float) -> np.ndarray:
    """The forward-backward passes as they were written on numpy's scalars (the square the
    correctly rounded product)."""
    v = cap.copy()
    v[0] = 0.0
    for i in range(1, v.size):
        v[i] = min(v[i], np.sqrt(v[i - 1] * v[i - 1] + 2.0 * accel * dz))
    v[-1] = 0.0
    for i in range(v.size - 2, -1, -1):
        v[i] = min(v[i], np.sqrt(v[i + 1] * v[i + 1] + 2.0 * accel * dz))
    return v


def test_the_compiled_passes_are_the_numpy_scalars_bit_for_bit():
    rng = np.random.default_rng(7)
    for k in range(200):
        n = int(rng.integers(2, 5000))
        cap = rng.uniform(0.0, 1.5, n) * (rng.uniform(size=n) > 0.05)  # some zero caps
        accel, dz = float(rng.uniform(1e-4, 0.05)), float(rng.uniform(1e-3, 1.0))
        want = _passes_before(cap, accel, dz)
        got = _passes(cap.copy(), float(2.0 * accel * dz))
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64)), k


def test_valve_profile_binds_and_is_finite():
    """A purge limit that binds gives a profile slower than the plain speed (the passes ran)."""
    p = valve_profile(300.0, 0.5, 0.01, np.array([400.0]), np.array([500.0]), 0.5, 0.8,
                      350.0, 101325.0, 1025.0 * 9.81)
    assert p is not None and p.limit_from is not None
    assert np.all(np.isfinite(p.v)) and 0.0 < p.v.max() < 0.5 and p.v[0] == 0.0


def test_shear_moment_at_kept_points_is_the_full_result_there():
    rng = np.random.default_rng(3)
    x = np.sort(np.concatenate([np.linspace(0.0, 200.0, 301), [50.0, 50.0, 120.0]]))
    q = rng.normal(size=(17, x.size)) * 1e4
    pts = [(50.0, rng.normal(size=17) * 1e6), (0.0, 3e5), (133.3, rng.normal(size=17) * 1e6),
           (200.0, -1e5)]
    keep = np.sort(rng.choice(x.size, 60, replace=False))
    V, M = shear_moment(x, q, pts)
    Vk, Mk = shear_moment(x, q, pts, keep)
    assert Vk.shape == (17, 60)
    assert np.array_equal(Vk, V[:, keep]) and np.array_equal(Mk, M[:, keep])


CASE_B = {"gas.fill_rate_max_m3_s": 0.55, "gas.purge_rate_max_m3_s": 1.7,
          "seabed.breakout_time_s": 300.0}
CASE_A = {"gas.fill_rate_max_m3_s": 0.45, "gas.purge_rate_max_m3_s": 2.3,
          "seabed.breakout_time_s": 300.0}

_FRESH = """
import json, sys
from flexlift import load_scenario
from flexlift.sweep.worker import Task, run_case
changes = json.loads(sys.argv[1])
record, _ = run_case(Task(1, load_scenario("tanker"), changes, ("coordinated",), False))
print(json.dumps(record))
"""


def _plain(record: dict) -> dict:
    return {k: v for k, v in record.items() if k not in ("elapsed_s", "pid", "host")}


def test_a_case_after_another_is_the_case_in_a_fresh_process():
    """The worker's caches (plan, plant, strength grid) warm from another case give the
    record a cold process gives, number for number."""
    import json
    import os
    import subprocess
    import sys

    from flexlift import load_scenario
    from flexlift.sweep.worker import Task, run_case

    base = load_scenario("tanker")
    run_case(Task(0, base, CASE_A, ("coordinated",), False))
    warm, _ = run_case(Task(1, base, CASE_B, ("coordinated",), False))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    out = subprocess.run([sys.executable, "-c", _FRESH, json.dumps(CASE_B)], env=env,
                         capture_output=True, text=True, timeout=600, check=True)
    cold = json.loads(out.stdout.strip().splitlines()[-1])
    assert warm["status"] == "completed"
    assert _plain(json.loads(json.dumps(warm))) == _plain(cold)


def test_the_strength_grid_is_shared_by_plants_of_the_same_hull_and_bags():
    from flexlift import load_scenario
    from flexlift.ascent import strength as S
    from flexlift.ascent.plant import coupled_plant

    base = load_scenario("tanker")
    a = coupled_plant(base.with_changes(**CASE_A))
    b = coupled_plant(base.with_changes(**CASE_B))
    assert a is not b and S.grid_key(a) == S.grid_key(b)
    assert S.strength_grid(a) is S.strength_grid(b)
    for got, want in zip(S.strength_grid(b), S.plant_grid(b)):
        assert np.array_equal(got, want)
    # other hulls and meshes after the tanker's grid is kept: each its own grid
    others = [base.with_changes(**{"hull.elements": base.hull.elements + 4}),
              base.with_changes(**{"simulation.retained_flexible_modes":
                                   base.simulation.retained_flexible_modes + 2}),
              load_scenario(str(TRAWLER))]
    for sc in others:
        p = coupled_plant(sc)
        assert S.grid_key(p) != S.grid_key(a)
        for got, want in zip(S.strength_grid(p), S.plant_grid(p)):
            assert np.array_equal(got, want)


@pytest.mark.parametrize("mode", ["decentralized", "coordinated"])
def test_all_cluster_keys_at_once_are_each_bags_key(mode):
    """The 73-bag plan (8 alike at each lift point), the pipeline's internal bags and the
    tanker: the keys built at once are each bag's :func:`cluster_key`, byte for byte."""
    from flexlift import load_scenario
    from flexlift.ascent.clusters import cluster_key, cluster_keys
    from flexlift.ascent.plant import coupled_plant
    from flexlift.control.build import controller_for, fuzzy_maps

    fifty = load_scenario(str(BAGS)).with_changes(**{"lift.catalogue_bag.lift_t": 50.0})
    for sc in (fifty, load_scenario("pipeline"), load_scenario("tanker")):
        P = coupled_plant(sc)
        table, _, fill = fuzzy_maps(sc)
        C = controller_for(sc, P, mode, table, fill)[0]
        keys = cluster_keys(P, C)
        assert keys == [cluster_key(P, C, i) for i in range(len(P.names))]
        if sc is fifty:
            assert len(set(keys)) < len(keys)  # the 73 bags do share


def test_compiled_integrals_are_numpys_bit_for_bit():
    """The run's strength integrates its line loads compiled: the same sums in the same order
    as :func:`line_integrals` (jumps, uneven spacing, many rows)."""
    from flexlift.ascent.strength import compiled_integrals
    from flexlift.loads.strength import line_integrals

    rng = np.random.default_rng(11)
    for n in (2, 3, 445, 1200):
        x = np.sort(np.concatenate([rng.uniform(0.0, 180.0, n - 2), [0.0, 180.0]]))
        x[n // 2] = x[n // 2 - 1]  # a jump
        q = rng.normal(size=(23, n)) * 1e5
        for got, want in zip(compiled_integrals(x, q), line_integrals(x, q)):
            assert got.shape == want.shape
            assert np.array_equal(got.view(np.uint64), want.view(np.uint64)), n


SUMMARY_CASES = {
    "tanker": ("tanker", {}),
    "incomplete": ("tanker", {"simulation.duration_s": 2500.0}),
    "never separated": ("tanker", {"simulation.duration_s": 600.0}),
    "unsafe": ("tanker", {"limits.ascent_velocity_m_s": 0.12}),
    "not achieved": ("tanker", {"control.volume_deadband_m3": 5.0,
                                "limits.arrival_tolerance_m": 0.2}),
    "pipeline": ("pipeline", {}),
    "trawler": (str(TRAWLER), {}),
}


@pytest.mark.parametrize("name,mode", [(n, m) for n in SUMMARY_CASES
                                       for m in ("coordinated", "paper") if n != "trawler"]
                         + [("trawler", "decentralized")])
def test_a_summary_only_case_is_the_full_cases_summary(name, mode):
    """``keep: summary`` builds no Dataset (a :class:`Frame` of the same arrays): the digest a
    sweep records, and the run's summary, are the full result's, value for value, for safe,
    unsafe, not-achieved, incomplete and never-separated runs, on three structures and the
    paper's plant."""
    import json

    from flexlift import load_scenario
    from flexlift.ascent import simulate
    from flexlift.ascent.result import Frame
    from flexlift.sweep.worker import _one_mode

    base, changes = SUMMARY_CASES[name]
    sc = load_scenario(base).with_changes(**changes)
    light, frame = _one_mode(sc, mode, summary_only=True)
    full, ds = _one_mode(sc, mode, summary_only=False)
    assert json.dumps(light, sort_keys=True) == json.dumps(full, sort_keys=True)
    assert isinstance(frame, Frame) and not isinstance(ds, Frame)
    a = simulate(sc, control=mode, summary_only=True)
    b = simulate(sc, control=mode)
    assert json.dumps(a.summary(), sort_keys=True) == json.dumps(b.summary(), sort_keys=True)
    assert a.dataset.attrs == b.dataset.attrs
    for name_, (dims, values, *_) in a.dataset.variables.items():
        assert tuple(b.dataset[name_].dims) == ((dims,) if isinstance(dims, str) else dims)
        assert np.array_equal(np.asarray(values), b.dataset[name_].values, equal_nan=True) \
            if np.asarray(values).dtype.kind == "f" else \
            np.array_equal(np.asarray(values), b.dataset[name_].values)
    assert set(a.dataset.variables) == set(b.dataset.variables)


def test_a_frames_max_skips_nan_as_xarrays_does():
    import xarray as xr

    from flexlift.ascent.result import Frame

    for vals in ([1.0, np.nan, 3.0], [np.nan, np.nan], [2.0, -1.0]):
        arr = np.array(vals)
        f = Frame({"u": (("x",), arr, {})}, {})
        want = float(xr.DataArray(arr).max())
        got = float(f["u"].max())
        assert (np.isnan(got) and np.isnan(want)) or got == want
        assert "u" in f and "v" not in f and np.array_equal(f.u.values, arr, equal_nan=True)
