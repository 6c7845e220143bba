import json

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.output.results import BAG_VARS, CRITERIA, HULL_VARS, load_netcdf, save_netcdf, to_csv


@pytest.fixture(scope="module")
def short():
    sc = load_scenario("tanker").with_changes(**{"control.target_height_m": 20.0,
                                                 "seabed.breakout_time_s": 60.0,
                                                 "simulation.hold_time_s": 30.0})
    return simulate(sc, duration=900.0)


def test_dataset_has_named_dims_and_units(short):
    ds = short.dataset
    assert set(ds.height.dims) == {"time", "bag"}
    assert set(ds.bending_moment.dims) == {"time_strength", "x"}
    for name in list(BAG_VARS) + list(HULL_VARS) + ["moment_max", "shear_force"]:
        assert ds[name].attrs["units"], name
    assert list(ds.bag.values) == [f"bag_{k}" for k in range(1, 8)]
    assert set(short.criteria) == set(CRITERIA)


def test_strength_closes_at_the_bow(short):
    """The dynamic load case is in equilibrium: V and M vanish at the aft end (where the
    integration starts) and close at the bow to ~1e-7 of their peaks (5e-8 and 2e-7 here:
    the bound leaves 50x)."""
    ds = short.dataset
    V, M = ds.shear_force.values, ds.bending_moment.values
    assert np.all(V[:, 0] == 0.0) and np.all(M[:, 0] == 0.0)
    assert np.abs(V[:, -1]).max() < 1e-5 * np.abs(V).max()
    assert np.abs(M[:, -1]).max() < 1e-5 * np.abs(M).max()


def test_the_compiled_line_loads_are_the_arrays_expression(monkeypatch):
    """The strength's weight, inertia, drag and seabed line loads, one compiled pass, are
    numpy's expression of the same arrays bit for bit (signs of zero too), with the internal
    bags' spans added after, on the tanker's short run and on a current (the drag on the
    relative speed)."""
    from flexlift.ascent import loop
    from flexlift.ascent import result as R
    from flexlift.ascent import strength as S
    from flexlift.physics import hydro

    runs = []
    real = loop.build_result
    monkeypatch.setattr(loop, "build_result", lambda run, *a: runs.append(run) or real(run, *a))
    sc = load_scenario("tanker").with_changes(**{"seabed.breakout_time_s": 60.0})
    simulate(sc, duration=400.0)
    simulate(sc.with_changes(**{"disturbance.current_m_s": 0.3}), duration=400.0)
    for run in runs:
        P, snaps = run.plant, R.snapshots(run)
        _, xe, _ = S.strength_grid(P)
        G = S._Grid.of(P, xe)
        acc, v = snaps["a"] @ G.psi.T, snaps["v"] @ G.psi.T
        ref = -G.weight - G.mass * acc
        ref += hydro.drag(v - snaps["current"][:, None], G.drag)
        ref += S.seabed_loads(P, snaps)[:, G.cell] * G.spread
        for i, span in enumerate(P.spans):  # the internal bags' buoyancy over their spans
            if span is not None:
                lift = S.gas.buoyancy(snaps["V"][:, i], P.bags.rho_g) * snaps["attached"][:, i]
                cols = np.flatnonzero((xe >= span[0]) & (xe <= span[1]))
                ref[:, cols] += (lift / (span[1] - span[0]))[:, None]
        got = S.line_loads(P, xe, snaps, G)
        assert np.array_equal(got, ref) and np.array_equal(np.signbit(got), np.signbit(ref))


def test_netcdf_round_trip(short, tmp_path):
    path = save_netcdf(short, tmp_path / "r.nc")
    back = load_netcdf(path)
    for name in ("height", "bending_moment", "gas_volume", "arrival_time"):
        np.testing.assert_array_equal(back.dataset[name].values, short.dataset[name].values)
    assert back.events == short.events
    assert back.criteria == short.criteria
    assert back.summary() == short.summary()
    assert back.dataset.height.attrs["units"] == "m"
    assert list(back.dataset.bag_kind.values) == list(short.dataset.bag_kind.values)


def test_csv(short, tmp_path):
    paths = to_csv(short, tmp_path, prefix="x")
    head = paths[0].read_text().splitlines()
    assert head[0].startswith("time [s],heave [m]")
    assert "height_bag_1 [m]" in head[0]
    assert len(head) == short.dataset.time.size + 1
    assert paths[1].read_text().startswith("x [m],moment_max [N m]")


def test_summary_is_json(short):
    s = short.summary()
    json.dumps(s, allow_nan=False)
    assert set(s["arrival_time_s"]) == set(s["final_height_m"]) == set(short.dataset.bag.values)
    assert all(isinstance(v, bool) for v in s["criteria"].values())


def _csv_value_by_value(cols, arr) -> str:
    """The writer as it was (one f-string per value): the reference for the fast one."""
    lines = [",".join(cols)]
    for row in arr:
        lines.append(",".join("" if not np.isfinite(v) else f"{v:.6g}" for v in row))
    return "\n".join(lines) + "\n"


def test_csv_writer_writes_what_it_wrote_value_by_value(short):
    from flexlift.output.results import _csv

    rng = np.random.default_rng(3)
    arr = rng.standard_normal((50, 6)) * 10.0 ** rng.integers(-12, 12, (50, 6))
    arr[3, 2], arr[7, 0], arr[7, 5], arr[9, 1] = np.nan, np.inf, -np.inf, -0.0
    arr[11] = np.nan
    cols = [f"c{k}" for k in range(6)]
    assert _csv(cols, arr) == _csv_value_by_value(cols, arr)
    assert _csv(cols, arr[:0]) == "c0,c1,c2,c3,c4,c5\n"
    ds = short.dataset
    real = np.column_stack([ds.time.values, ds.heave.values, ds.height.values])
    assert _csv(["a"] * real.shape[1], real) == _csv_value_by_value(["a"] * real.shape[1], real)


def test_buoyancy_and_sling_force_are_told_apart(short, tmp_path):
    """``buoyancy`` is rho g V of the bag's gas; ``sling_force`` what its sling pulls on the
    hull: the buoyancy less the drag while the bag rises (issue 23: once both were "lift")."""
    ds = short.dataset
    rho_g = 1025.0 * 9.81
    np.testing.assert_allclose(ds.buoyancy.values, rho_g * ds.gas_volume.values, rtol=1e-12)
    assert ds.buoyancy.attrs["units"] == "N" and "sling" in ds.sling_force.attrs["long_name"]
    ext = ds.bag_kind.values == "external"
    v = ds.ascent_velocity.values[:, ext]
    B, S = ds.buoyancy.values[:, ext], ds.sling_force.values[:, ext]
    rising = v > 0.05
    assert rising.any() and np.all(S[rising] < B[rising])
    held = np.abs(v) < 1e-9
    assert held.any()
    np.testing.assert_allclose(S[held], B[held], rtol=1e-9)
    # written and read back with both names; an earlier file's "lift" is its sling force
    back = load_netcdf(save_netcdf(short, tmp_path / "r.nc")).dataset
    np.testing.assert_array_equal(back.buoyancy.values, ds.buoyancy.values)
    old = ds.drop_vars("buoyancy").rename({"sling_force": "lift"})
    old["bag_kind"] = old["bag_kind"].astype("S8")
    old.to_netcdf(tmp_path / "old.nc", engine="scipy")
    np.testing.assert_array_equal(load_netcdf(tmp_path / "old.nc").dataset.sling_force.values,
                                  ds.sling_force.values)
    head = to_csv(short, tmp_path, prefix="y")[0].read_text().splitlines()[0]
    assert "sling_force_bag_1 [N]" in head and "buoyancy_bag_1 [N]" in head


def test_bending_utilisation_is_a_lift_criterion(short):
    """The dynamic bending utilisation over the ascent <= 1 is a lift criterion, with its cause
    when it fails (here the tanker's hull given a 20 MPa allowable stress)."""
    assert short.criteria["bending_utilisation"] is True
    assert short.headline["max_utilisation"] < 1
    sc = load_scenario("tanker").with_changes(**{"hull.allowable_stress_MPa": 20.0,
                                                 "control.target_height_m": 20.0,
                                                 "seabed.breakout_time_s": 60.0})
    weak = simulate(sc, duration=300.0)
    assert weak.criteria["bending_utilisation"] is False
    u = weak.headline["max_utilisation"]
    assert u > 1
    why = weak.reasons["bending_utilisation"]
    assert f"utilisation {u:.2f}" in why and "20 MPa" in why and "MN m" in why
