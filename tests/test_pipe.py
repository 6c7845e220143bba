"""The pipe section (docs/theory/statics.md#pipe-section): properties against hand values, the derived hull, bad input."""

import math

import numpy as np
import pytest

from flexlift.cli import main
from flexlift.errors import InputError
from flexlift.physics.pipe import Section
from flexlift.scenario.schema import parse_scenario
from flexlift.structure.hull import hull_from_scenario

BASE = {"name": "p", "environment": {"water_depth_m": 100.0},
        "control": {"target_height_m": 50.0}}


def _scenario(**pipe):
    return parse_scenario({**BASE, "pipe": pipe})


def test_20_inch_section_against_hand_values():
    """508 mm x 15.9 mm X65 steel (7850 kg/m3, E 207 GPa), 60 mm concrete at 3044 kg/m3,
    empty, seawater 1025 kg/m3, g 9.81 m/s2. By hand (4 significant figures):

    D_i = 0.508 - 2 (0.0159) = 0.4762 m
    D^4 = 0.06660, D_i^4 = 0.05142 -> I = pi/64 (0.01517) = 7.448e-4 m^4
    EI = 207e9 x 7.448e-4 = 1.542e8 N m^2;  Z = I / 0.254 = 2.932e-3 m^3
    steel   7850 x pi/4 (0.258064 - 0.226766) = 7850 x 0.024582 = 193.0 kg/m
    coating D_c = 0.628 m: 3044 x pi/4 (0.394384 - 0.258064) = 3044 x 0.107065 = 325.9 kg/m
    mass 518.9 kg/m; displaced pi/4 0.394384 = 0.3097 m^3/m -> 317.5 kg/m of seawater
    wet weight q = (518.9 - 317.5) 9.81 = 1976 N/m (201.4 kg/m)
    flooded: + 1025 x pi/4 0.4762^2 = 182.6 kg/m -> q = 3767 N/m
    sigma at M = 1 MN m: 1e6 x 0.254 / 7.448e-4 = 341.0 MPa
    """
    s = Section(D=0.508, t=0.0159, rho_steel=7850, E=207e9, smys=448e6, t_coat=0.060,
                rho_coat=3044)
    assert s.I == pytest.approx(7.448e-4, rel=1e-3)
    assert s.EI == pytest.approx(1.542e8, rel=1e-3)
    assert s.Z == pytest.approx(2.932e-3, rel=1e-3)
    assert s.steel_mass == pytest.approx(193.0, rel=1e-3)
    assert s.coating_mass == pytest.approx(325.9, rel=1e-3)
    assert s.mass == pytest.approx(518.9, rel=1e-3)
    assert s.displaced_volume == pytest.approx(0.3097, rel=1e-3)
    assert s.wet_weight(9.81, 1025) == pytest.approx(1976, rel=1e-3)
    assert float(s.stress(1e6)) == pytest.approx(341.0e6, rel=1e-3)
    flooded = Section(D=0.508, t=0.0159, rho_steel=7850, E=207e9, smys=448e6, t_coat=0.060,
                      rho_coat=3044, contents_density=1025)
    assert flooded.contents_mass == pytest.approx(182.6, rel=1e-3)
    assert flooded.wet_weight(9.81, 1025) == pytest.approx(3767, rel=1e-3)


def test_scenario_pipe_fills_the_hull_and_the_wet_weight():
    s = _scenario(contents="flooded", elements=100, length_m=500.0)
    h = s.hull
    assert h.length_m == 500 and h.elements == 100 and h.displacement_t is None
    assert h.mass_per_length_kg_m == pytest.approx(518.9 + 182.6, rel=1e-3)
    assert h.bending_stiffness_Nm2 == pytest.approx(1.542e8, rel=1e-3)
    assert h.breadth_m == pytest.approx(0.628)
    assert h.allowable_stress_MPa == pytest.approx(0.72 * 448)
    hull = hull_from_scenario(s)
    q = hull.wet_weight_per_length(9.81, 1025, 7850)
    assert q == pytest.approx(np.full(100, 3767), rel=1e-3)
    assert hull.total_wet_weight(9.81, 1025, 7850) == pytest.approx(3767 * 500, rel=1e-3)
    # the derived scenario survives its own round trip (with_changes dumps and re-validates)
    again = s.with_changes(**{"pipe.elements": 100})
    assert again.hull == s.hull


def test_segments_and_point_masses():
    s = _scenario(length_m=100.0, elements=10, point_masses=[{"x_m": 51.0, "mass_t": 2.0}],
                  segments=[{"from_m": 80.0, "to_m": 100.0, "wall_thickness_m": 0.0254}])
    m, EI = s.hull.mass_per_length_kg_m, s.hull.bending_stiffness_Nm2
    assert len(m) == 10 and m[0] == m[7] and m[8] == m[9] > m[7]
    heavy = Section(D=0.508, t=0.0254, rho_steel=7850, E=207e9, smys=448e6, t_coat=0.06,
                    rho_coat=3044)
    assert EI[9] == pytest.approx(heavy.EI) and EI[0] < EI[9]
    assert [(p.node, p.mass_t) for p in s.hull.point_masses] == [(6, 2.0)]
    hull = hull_from_scenario(s)
    W = hull.total_wet_weight(9.81, 1025, 7850)
    q = hull.wet_weight_per_length(9.81, 1025, 7850)
    assert W == pytest.approx(q.sum() * 10 + 2000 * 9.81 * (1 - 1025 / 7850))


def test_lift_points_sized_from_the_wet_weight_they_carry():
    s = _scenario(length_m=1000.0, elements=200, lift_points={"spacing_m": 50.0})
    bags = s.lift.bags
    assert len(bags) == 20 and bags[0].node == 6 and bags[-1].node == 196  # 25 m, 975 m
    # each carries 50 m x 1976 N/m x breakout 1.3 = 13.09 t, rounded up to 0.1 t
    assert {b.lift_t for b in bags} == {math.ceil(50 * 1975.5 * 1.3 / 9810 * 10) / 10}
    p = _scenario(length_m=1000.0, elements=200, breakout_suction_kN_m=1.0,
                  lift_points={"positions_m": [100.0, 500.0, 900.0], "count": 2})
    # breakout factor 1 + 1000 N/m / 1975.5 N/m
    assert p.lift.breakout_factor == pytest.approx(1 + 1000 / 1975.5, rel=1e-3)
    # ends: the first point carries 0..300 m, the middle one 300..700 m, each of 2 bags half
    assert [b.count for b in p.lift.bags] == [2, 2, 2]
    assert p.lift.bags[0].lift_t == pytest.approx(300 * 1975.5 * p.lift.breakout_factor
                                                  / 9810 / 2, abs=0.1)
    assert p.seabed.holding_shape == "uniform"


@pytest.mark.parametrize("pipe, needle", [
    ({"wall_thickness_m": 0.3}, "must be less than the radius"),
    ({"segments": [{"from_m": 0, "to_m": 10, "wall_thickness_m": 0.26}]}, "segments[0]"),
    ({"coating_density_kg_m3": 0.0}, "pipe.coating_density_kg_m3"),
    ({"contents": -5.0}, "pipe.contents"),
    ({"lift_points": {"positions_m": [10.0, 1200.0]}}, "off the line"),
    ({"point_masses": [{"x_m": 1500.0, "mass_t": 1.0}]}, "off the line"),
])
def test_bad_pipe_is_one_line(pipe, needle):
    with pytest.raises(InputError) as exc:
        _scenario(**pipe)
    assert needle in str(exc.value) and "\n" not in str(exc.value)


def test_hull_number_contradicting_the_pipe(tmp_path, capsys):
    path = tmp_path / "s.yaml"
    path.write_text("environment: {water_depth_m: 100}\ncontrol: {target_height_m: 50}\n"
                    "pipe: {wall_thickness_m: 0.3}\n")
    assert main(["loads", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "wall_thickness_m" in err[0]
    path.write_text("environment: {water_depth_m: 100}\ncontrol: {target_height_m: 50}\n"
                    "pipe: {elements: 20}\nhull: {elements: 11}\n")
    assert main(["loads", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "hull.elements is derived from the pipe" in err[0]


def test_builtin_pipeline_scenario():
    from flexlift import load_scenario
    from flexlift.scenario import builtin_names

    assert "pipeline" in builtin_names()
    s = load_scenario("pipeline")
    assert s.pipe is not None and s.hull.elements == 1000 and len(s.lift.bags) == 40
    assert s.lift.breakout_factor == pytest.approx(1 + 500 / 1975.5, rel=1e-3)
    assert all(b.lift_t <= s.lift.catalogue_bag.lift_t for b in s.lift.bags)


def test_with_changes_on_a_pipe_derives_the_hull_anew():
    """Changing a pipe key (as a sweep or a mesh study does) re-derives the hull and the bags."""
    from flexlift import load_scenario

    sc = load_scenario("pipeline")
    fine = sc.with_changes(**{"pipe.elements": 2000})
    assert fine.hull.elements == 2000 and fine.pipe.elements == 2000
    assert len(fine.lift.bags) == len(sc.lift.bags)
    thick = sc.with_changes(**{"pipe.wall_thickness_m": 0.0254})
    assert thick.hull.bending_stiffness_Nm2 != sc.hull.bending_stiffness_Nm2
    assert sc.with_changes(**{"control.target_height_m": 70.0}).hull == sc.hull
