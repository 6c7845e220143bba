"""The phases of a single-failure study from a fault-free run's events (issue 26,
flexlift.sweep.contingency.phases)."""

import numpy as np
import pytest
import xarray as xr

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.errors import InputError
from flexlift.sweep.contingency.phases import find_phases, parse_phases

SC = load_scenario("tanker")


def _synthetic(target=100.0):
    """Two bags: filling from 20 s, rising 1 m/s from 100 s to the target; the gas volume peaks
    at 170 s (and is higher at the start, before the ascent's upper half: not its peak)."""
    t = np.arange(0.0, 301.0)
    z = np.clip(t - 100.0, 0.0, target)
    height = np.column_stack([z, z + 2.0])
    fill = np.where(t >= 20.0, 0.5, 0.0)[:, None] * np.ones(2)
    V = 200.0 - np.abs(t - 170.0)[:, None] * np.ones(2)
    V[:30] = 300.0
    return xr.Dataset({"height": (("time", "bag"), height), "fill_rate": (("time", "bag"), fill),
                       "gas_volume": (("time", "bag"), V)}, coords={"time": t})


def test_phases_of_a_synthetic_run_are_where_their_definitions_put_them():
    sc = SC.with_changes(**{"control.target_height_m": 100.0, "seabed.release_time_s": 30.0})
    ds = _synthetic()
    events = [{"kind": "separation", "time_s": 90.0, "bag": None}]
    ph = {p.name: p.time_s for p in find_phases(ds, events, sc, times=(250.0,))}
    assert ph["pull"] == 55.0  # (20 + 90) / 2
    assert ph["breakout"] == 120.0  # 90 + 30
    assert ph["mid"] == 149.0  # mean height (z + 1) first >= 50 m at z = 49
    assert ph["near_target"] == 170.0  # the volume's peak (90 % = 90 m at 189 s: later)
    assert ph["t250"] == 250.0
    # 90 % of the target reached before the volume peaks: that time
    sc2 = SC.with_changes(**{"control.target_height_m": 60.0})
    ph2 = {p.name: p.time_s for p in find_phases(ds, events, sc2)}
    assert ph2["near_target"] == 153.0  # mean (z + 1) >= 54 at z = 53


def test_phases_of_a_run_that_never_separated_are_not_reached():
    ds = _synthetic()
    ph = {p.name: p for p in find_phases(ds, [], SC)}
    assert ph["pull"].time_s is None and "never separated" in ph["pull"].how
    assert ph["mid"].time_s is None


def test_the_tankers_phases_from_its_baseline_events():
    r = simulate(SC)
    sep = r.headline["separation_time_s"]
    assert sep == pytest.approx(1877.5, abs=0.1)  # the pinned fault-free separation
    ph = {p.name: p.time_s for p in find_phases(r.dataset, r.events, SC)}
    assert ph["pull"] == pytest.approx(0.5 * sep, abs=0.1)  # the tanker fills from 0 s
    assert ph["breakout"] == pytest.approx(sep + SC.seabed.release_time_s, abs=0.1)
    t = r.dataset.time.values
    mean_z = r.dataset.height.values.mean(axis=1)
    k = int(np.searchsorted(t, ph["mid"]))
    assert mean_z[k] >= 150.0 > mean_z[k - 1]  # half the 300 m target
    assert ph["breakout"] < ph["mid"] < ph["near_target"] <= r.headline["end_time_s"]
    k = int(np.searchsorted(t, ph["near_target"]))
    assert mean_z[k] >= 270.0 > mean_z[k - 1]  # the volume is held level up to the target


def test_a_time_outside_the_run_and_an_unknown_phase_are_one_line():
    ds = _synthetic()
    with pytest.raises(InputError, match="inside the fault-free run, 0 to 300 s"):
        find_phases(ds, [], SC, names=(), times=(301.0,))
    with pytest.raises(InputError, match="use pull, breakout, mid, near_target"):
        parse_phases(["pul"])
    assert parse_phases(["mid", "t1800", "90s", "mid"]) == (("mid",), (1800.0, 90.0))
    # beyond the scenario's run length, echoed as the user wrote it (issue 40)
    with pytest.raises(InputError, match=r"--phases: got '1e30'; a time in seconds from 0 to "
                       r"6000 s"):
        parse_phases(["1e30"], 6000.0)
    with pytest.raises(InputError, match="name at least one phase"):
        parse_phases([])
