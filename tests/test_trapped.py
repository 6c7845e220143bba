"""The hull's trapped water on the final lift through the surface (docs/theory/trapped-water.md):
each term of flexlift.loads.trapped against what it must give alone."""

import math
from dataclasses import replace

import numpy as np
import pytest

from flexlift import constants as C
from flexlift.errors import InputError
from flexlift.loads import trapped as T
from flexlift.structure.hull import Hull

MASS = 70_000.0  # kg of steel
RHO_G = C.RHO_SEAWATER * C.G
BASE = T.Surfacing(hull_depth_m=2.5, trapped_volume_m3=60.0, opening_area_m2=0.05,
                   lift_speed_m_s=0.05, start_depth_m=1.0, clearance_m=1.0, hold_s=3000.0)


def test_a_submerged_hull_weighs_its_wet_weight_exactly():
    """Before its top reaches the surface the hull is full and the sea all round it: the force
    is W', the same number the project's Hull gives for that steel."""
    h = T.force_history(MASS, BASE, step_s=0.5)
    hull = Hull.uniform(10.0, 1e9, MASS / 10.0, 4)
    w_prime = hull.total_wet_weight(C.G, C.RHO_SEAWATER, C.RHO_STEEL)
    submerged = h.time <= BASE.kinks()[0]
    assert submerged.sum() >= 20
    np.testing.assert_allclose(h.force[submerged], w_prime, rtol=1e-12)
    np.testing.assert_allclose(h.level_in[submerged], BASE.hull_depth_m, rtol=1e-9)
    assert h.weight_in_water == pytest.approx(w_prime, rel=1e-12)
    assert T.mass_for_weight_in_water(w_prime) == pytest.approx(MASS, rel=1e-12)


def test_without_drainage_the_peak_is_the_weight_in_air_and_all_the_water():
    """No openings: nothing drains, so once the keel is out the force is m g + rho_w g V_t,
    and it stays there."""
    s = replace(BASE, opening_area_m2=0.0)
    h = T.force_history(MASS, s)
    full = MASS * C.G + RHO_G * s.trapped_volume_m3
    assert h.peak == pytest.approx(full, rel=1e-12)
    assert h.force[-1] == pytest.approx(full, rel=1e-12)
    assert h.peak_time == pytest.approx(s.kinks()[1], abs=1.0)


def test_without_trapped_water_no_spike_a_monotone_rise_to_the_weight_in_air():
    """V_t = 0: the force rises from W' as the steel leaves the water, linearly while it
    crosses the surface, never above its weight in air."""
    h = T.force_history(MASS, replace(BASE, trapped_volume_m3=0.0))
    assert np.all(np.diff(h.force) >= -1e-6)
    assert h.force[0] == pytest.approx(h.weight_in_water, rel=1e-12)
    assert h.peak == pytest.approx(MASS * C.G, rel=1e-12)
    t_top, t_keel, _ = BASE.kinks()
    mid = (t_top + t_keel) / 2
    k = np.argmin(np.abs(h.time - mid))
    half = 0.5 * (h.weight_in_water + h.weight_in_air)
    assert h.force[k] == pytest.approx(half, rel=1e-9)  # half the steel out, half its buoyancy


def test_the_drained_level_is_the_weight_in_air():
    """Once the water is gone the crane holds the steel in air: m g, whatever the openings."""
    for area in (0.02, 0.2):
        h = T.force_history(MASS, replace(BASE, opening_area_m2=area))
        assert h.force[-1] == pytest.approx(MASS * C.G, rel=1e-6)
        assert not math.isnan(h.drained_time())


def _empty_time(s: T.Surfacing) -> tuple[float, float]:
    """(the inside level at the lift's stop [m], the time from then to empty [s])."""
    h = T.force_history(MASS, s, step_s=0.05)
    t_stop = s.kinks()[2]
    k = np.searchsorted(h.time, t_stop)
    empty = h.time[np.argmax((h.time > t_stop) & (h.level_in <= 1e-9))]
    return float(h.level_in[k]), float(empty - t_stop)


def test_drainage_time_follows_torricelli():
    """Out of the water the openings discharge freely: a prism of plan area A empties from h1
    in (A / (C_d a)) sqrt(2 h1 / g); twice the area, half the time; C_d scales it too."""
    h1, t = _empty_time(BASE)
    A = BASE.plan_area_m2
    expected = A / (BASE.discharge_coefficient * BASE.opening_area_m2) * math.sqrt(2 * h1 / C.G)
    assert 0.5 < h1 < BASE.hull_depth_m
    assert t == pytest.approx(expected, rel=2e-3)
    h1b, t2 = _empty_time(replace(BASE, opening_area_m2=0.1))
    assert t2 / math.sqrt(h1b) == pytest.approx(0.5 * t / math.sqrt(h1), rel=3e-3)
    h1c, t3 = _empty_time(replace(BASE, discharge_coefficient=0.305))
    assert t3 / math.sqrt(h1c) == pytest.approx(2.0 * t / math.sqrt(h1), rel=3e-3)


def test_the_peak_is_where_the_keel_leaves_the_water_and_less_than_undrained():
    """Draining while it rises, the hull's peak comes as the keel clears the surface and lies
    between the weight in air and the undrained peak; a slower lift drains more."""
    h = T.force_history(MASS, BASE, step_s=0.25)
    full = MASS * C.G + RHO_G * BASE.trapped_volume_m3
    assert MASS * C.G < h.peak < full
    assert h.peak_time == pytest.approx(BASE.kinks()[1], abs=0.5)
    slow = T.force_history(MASS, replace(BASE, lift_speed_m_s=0.02))
    assert slow.peak < h.peak


def test_drain_rate_signs():
    """Water leaves while it stands above the sea and comes in while below (a flooding hull),
    as the square root of the difference."""
    args = (0.05, 0.61, 20.0)
    assert T.drain_rate(2.0, 1.0, *args) < 0 < T.drain_rate(1.0, 2.0, *args)
    assert T.drain_rate(1.0, 1.0, *args) == 0.0
    assert T.drain_rate(5.0, 1.0, *args) == pytest.approx(2 * T.drain_rate(2.0, 1.0, *args))


def test_the_fit_inverts_the_history():
    """trapped_volume_for_peak gives back the volume a history was made with."""
    peak = T.force_history(MASS, BASE).peak
    assert T.trapped_volume_for_peak(MASS, peak, BASE) == pytest.approx(60.0, rel=1e-5)
    with pytest.raises(InputError, match="peak"):
        T.trapped_volume_for_peak(MASS, 0.9 * MASS * C.G, BASE)


@pytest.mark.parametrize("field,value", [("opening_area_m2", -0.1), ("lift_speed_m_s", 0.0),
                                         ("discharge_coefficient", 1.5),
                                         ("trapped_volume_m3", math.nan)])
def test_bad_input_names_the_field(field, value):
    with pytest.raises(InputError, match=f"surfacing.{field}"):
        replace(BASE, **{field: value})


# ------------------------------------------------------------------ the scenario and the CLI
def test_flexlift_surfacing_prints_writes_and_refuses(tmp_path, capsys):
    """`flexlift surfacing` on the shipped Lee vessel: its numbers printed and written; a
    scenario without a surfacing: section, a bad value in one, or a bad --step: one line on
    stderr naming it, exit 2."""
    import json

    from flexlift.cli import main

    assert main(["surfacing", "field-lee-vessel", "--json", "--out", str(tmp_path / "o")]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["weight_in_water_MN"] == pytest.approx(0.604, rel=1e-3)
    assert s["final_MN"] == pytest.approx(s["weight_in_air_MN"], rel=1e-6)
    written = json.loads((tmp_path / "o" / "surfacing.json").read_text())
    assert written["peak_MN"] == pytest.approx(s["peak_MN"])
    rows = (tmp_path / "o" / "tables" / "surfacing.csv").read_text().splitlines()
    assert rows[0] == "time_s,keel_height_m,level_in_m,waterline_m,force_MN"
    assert float(rows[1].split(",")[4]) == pytest.approx(s["weight_in_water_MN"], rel=1e-5)
    assert main(["surfacing", "field-lee-vessel"]) == 0
    out = capsys.readouterr().out
    assert "peak 1.380 MN" in out and "weight in air 0.695 MN" in out
    bad = tmp_path / "bad.yaml"
    from importlib import resources

    text = (resources.files("flexlift") / "scenarios" / "field-lee-vessel.yaml").read_text()
    bad.write_text(text.replace("opening_area_m2: 0.05", "opening_area_m2: -1"))
    for argv, needle in ((["surfacing", "tanker"], "surfacing"),
                         (["surfacing", str(bad)], "surfacing.opening_area_m2"),
                         (["surfacing", "field-lee-vessel", "--step", "0"], "--step")):
        try:
            code = main(argv)
        except SystemExit as stop:
            code = stop.code
        err = capsys.readouterr().err.strip().splitlines()
        assert code == 2 and len(err) == 1 and needle in err[0], (argv, err)
