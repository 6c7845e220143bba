"""Hydrostatics, the bag-count rule and the bag layouts."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flexlift import constants as C
from flexlift import load_scenario
from flexlift.errors import InputError
from flexlift.loads.liftplan import bag_count, plan_lift
from flexlift.structure.hull import hull_from_scenario
from flexlift.structure.modes import compute_modes, zero_crossings

T = C.TONNE * 9.81  # one tonne-force [N]


def _plan(**changes):
    s = load_scenario("tanker").with_changes(**changes)
    hull = hull_from_scenario(s)
    return plan_lift(s, hull, compute_modes(hull)), hull


# ----------------------------------------------------------------------------- tanker
def test_tanker_hydrostatics(tanker_plan):
    p = tanker_plan
    assert p.dry_weight / T == pytest.approx(3200.0, rel=1e-12)
    # W' = W (1 - rho_sw / rho_steel)
    assert p.wet_weight / T == pytest.approx(3200 * (1 - 1025 / 7850), rel=1e-12)
    assert p.wet_weight / T == pytest.approx(2782.17, abs=0.01)
    assert p.required_lift / T == pytest.approx(1.3 * 2782.1656, abs=0.01)
    assert p.required_lift / T == pytest.approx(3616.8, abs=0.05)


def test_tanker_bags(tanker_plan, tanker_hull, tanker_modes):
    p, hull = tanker_plan, tanker_hull
    assert p.bag_count == 7 and p.bag_lift / T == pytest.approx(517.0)
    assert p.catalogue_lift / T == pytest.approx(565.0)
    assert [b.name for b in p.bags] == [f"bag_{k}" for k in range(1, 8)]
    assert all(b.lift == pytest.approx(517 * T) for b in p.bags)
    assert all(b.capacity == pytest.approx(b.lift / (1025 * 9.81)) for b in p.bags)
    assert p.total_lift >= p.required_lift and p.shortfall == 0 and p.warnings == ()
    # external bags at the nodes of the third flexible mode: 1-based nodes 2, 5, 8, 11
    assert [b.node + 1 for b in p.external] == [2, 5, 8, 11]
    crossings = zero_crossings(tanker_modes, tanker_modes.flexible_index(3))
    assert len(crossings) == 4
    for b, xc in zip(p.external, crossings):
        assert abs(b.x - xc) <= hull.element_length / 2
        assert b.x == pytest.approx(hull.x_nodes[b.node])
    # internal bags: frames 27..113 at 0.57 m = 15.39..64.41 m, snapped to nodes 3..10
    ints = p.internal
    assert len(ints) == 3
    assert ints[0].span[0] == pytest.approx(hull.x_nodes[2]) == pytest.approx(14.19, abs=0.01)
    assert ints[-1].span[1] == pytest.approx(hull.x_nodes[9]) == pytest.approx(63.83, abs=0.01)
    lengths = [b.span[1] - b.span[0] for b in ints]
    assert lengths == pytest.approx([lengths[0]] * 3)
    for a, b in zip(ints, ints[1:]):
        assert a.span[1] == b.span[0]  # end to end
    assert all(b.x == pytest.approx(0.5 * sum(b.span)) for b in ints)


# ----------------------------------------------------------------------------- bag count
@pytest.mark.parametrize(
    "required, catalogue, n, per",
    [
        (3 * 565.0, 565.0, 3, 565.0),  # an exact multiple: no extra bag
        (3 * 565.0 + 1e-3, 565.0, 4, 424.0),  # just over: one more bag
        (3 * 565.0 - 1e-3, 565.0, 3, 565.0),  # just under, per-bag lift rounds up
        (565.0, 565.0, 1, 565.0),
        (1.0, 565.0, 1, 1.0),
        (3616.8152866, 565.0, 7, 517.0),  # the tanker: 6.4 -> 7 bags of 516.7 -> 517 t
        (1034.0, 565.0, 2, 517.0),  # per-bag lift an exact tonne stays
        (1033.5, 565.0, 2, 517.0),
        (0.1 * 3, 0.1, 3, 1.0),  # round-off in the ratio (0.30000000000000004 / 0.1)
    ],
)
def test_bag_count_rule(required, catalogue, n, per):
    got_n, got_per = bag_count(required, catalogue)
    assert (got_n, got_per) == (n, per)
    assert got_n == max(1, math.ceil(required / catalogue - 1e-9))
    assert got_n * got_per >= required - 1e-6  # the bags carry the required lift


@pytest.mark.parametrize("required, catalogue", [(0.0, 565.0), (-5.0, 565.0), (100.0, 0.0)])
def test_bag_count_rejects_non_positive(required, catalogue):
    with pytest.raises(InputError, match="lift"):
        bag_count(required, catalogue)


def test_required_exactly_three_catalogue_bags_gives_three_bags():
    # choose the displacement so that 1.3 W' is exactly 3 x 565 t
    disp = 3 * 565 / 1.3 / (1 - 1025 / 7850)
    p, _ = _plan(**{"hull.displacement_t": disp, "lift.internal_bags": 0, "lift.layout_flexible_mode": 2})
    assert p.required_lift / T == pytest.approx(1695.0, rel=1e-12)
    assert p.bag_count == 3 and p.bag_lift / T == 565.0
    # nodes of the second free-free mode at 0.132 L, 0.5 L, 0.868 L -> 1.45, 5.5, 9.55 elements
    assert [b.node + 1 for b in p.external] == [2, 6, 11]


def test_breakout_factor_and_bag_lift_override():
    p, _ = _plan(
        **{"lift.breakout_factor": 1.0, "lift.bag_lift_t": 500.0, "lift.layout_flexible_mode": 1}
    )
    assert p.required_lift == pytest.approx(p.wet_weight)
    assert p.bag_count == 5  # ceil(2782 / 565): 2 external at the nodes of mode 1, 3 internal
    assert [b.node + 1 for b in p.external] == [3, 10]  # 0.224 L, 0.776 L = 2.46, 8.54 elements
    assert all(b.lift == pytest.approx(500 * T) for b in p.bags)


def test_shortfall_is_a_warning_with_tonnes():
    p, _ = _plan(**{"lift.bag_lift_t": 400.0})
    assert p.bag_count == 7
    short_t = (p.required_lift - 7 * 400 * T) / T
    assert p.shortfall / T == pytest.approx(short_t) == pytest.approx(816.8, abs=0.1)
    assert len(p.warnings) == 1
    assert "817 t short" in p.warnings[0] and "3617 t required" in p.warnings[0]


# ----------------------------------------------------------------------------- explicit layouts
def test_explicit_layout():
    bags = [
        {"name": "aft", "kind": "external", "node": 2},
        {"name": "mid", "kind": "external", "x_m": 39.01},  # not on a node
        {"name": "fwd", "kind": "external", "x_m": 70.92727272727272},  # on node 11
        {"name": "tank_a", "kind": "internal", "span_m": [10.0, 30.0], "lift_t": 600.0},
        {"name": "tank_b", "kind": "internal", "span_m": [30.0, 50.0]},  # touching is fine
    ]
    p, hull = _plan(**{"lift.bags": bags})
    by = {b.name: b for b in p.bags}
    assert list(by) == ["aft", "mid", "fwd", "tank_a", "tank_b"]
    assert by["aft"].node == 1 and by["aft"].x == pytest.approx(hull.x_nodes[1])
    assert by["mid"].node is None and by["mid"].x == 39.01
    assert by["fwd"].node == 10
    assert by["tank_a"].span == (10.0, 30.0) and by["tank_a"].x == 20.0
    assert by["tank_a"].lift == pytest.approx(600 * T)
    assert by["tank_b"].lift == pytest.approx(517 * T)  # default: the rule's per-bag lift
    assert p.bag_count == 5
    assert p.shortfall / T == pytest.approx(p.required_lift / T - (4 * 517 + 600))
    assert p.warnings and "short" in p.warnings[0]


@pytest.mark.parametrize(
    "bags, match",
    [
        ([{"name": "b", "kind": "external", "x_m": 80.0}], r"lift\.bags\.b\.x_m: got 80\.0"),
        ([{"name": "b", "kind": "external", "node": 13}], r"lift\.bags\.b\.node: got 13"),
        ([{"name": "b", "kind": "internal", "span_m": [70.0, 79.0]}], r"lift\.bags\.b\.span_m"),
        (
            [
                {"name": "p", "kind": "internal", "span_m": [10.0, 30.0]},
                {"name": "q", "kind": "internal", "span_m": [29.0, 40.0]},
            ],
            "must not overlap",
        ),
    ],
)
def test_explicit_layout_errors(bags, match):
    with pytest.raises(InputError, match=match) as info:
        _plan(**{"lift.bags": bags})
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"lift.bag_lift_t": 0.0}, "bag_lift_t"),
        ({"lift.catalogue_bag.lift_t": -565.0}, "lift_t"),
        ({"lift.bags": [{"name": "b", "kind": "external", "node": 2, "lift_t": 0}]}, "lift_t"),
    ],
)
def test_zero_or_negative_lift_rejected_by_schema(changes, match):
    with pytest.raises(InputError, match=match):
        load_scenario("tanker").with_changes(**changes)


def test_mode_number_errors():
    with pytest.raises(InputError, match=r"lift\.layout_flexible_mode: got 23; the model has flexible modes 1\.\.22"):
        _plan(**{"lift.layout_flexible_mode": 23})
    with pytest.raises(InputError, match="has 3 nodes but the plan needs 4"):
        _plan(**{"lift.layout_flexible_mode": 2})
    with pytest.raises(InputError, match="fall on the same beam node"):
        _plan(**{"hull.elements": 2})


def test_ballast_tank_off_the_hull():
    with pytest.raises(InputError, match="ballast_tank_frames"):
        _plan(**{"hull.ballast_tank_frames": [27, 200]})


def test_all_internal_bags_need_no_mode():
    p, hull = _plan(**{"lift.internal_bags": 9, "lift.layout_flexible_mode": 99})
    assert p.bag_count == 7 and not p.external  # min(internal_bags, n)
    assert p.internal[0].span[0] == pytest.approx(hull.x_nodes[2])


def test_balance_moment_cost_is_the_static_moment_and_its_gradient():
    """refine minimises balance.moment_cost: its value must be the mean square of
    static_moment (strength.shear_moment) and its gradient the derivative of that."""
    from scipy.optimize import approx_fprime

    from flexlift.loads import balance

    x = np.linspace(0.0, 100.0, 401)
    q = 1e4 * (1.0 + 0.5 * np.sin(x / 15.0))
    pts = [(70.0, 2e5)]
    p = np.array([12.03, 41.01, 66.02, 88.04])
    lift = 3.1e5

    def cost(pp):
        return float(np.mean(balance.static_moment(x, q, pts, pp, lift)[1] ** 2))

    _, M0 = balance.static_moment(x, q, pts, [], lift)
    value, grad = balance.moment_cost(x, M0, p, lift)
    assert value == pytest.approx(cost(p), rel=1e-12)
    assert grad == pytest.approx(approx_fprime(p, cost, 1e-6), rel=1e-3)
    target = lift * p.sum()
    out = balance.refine(x, q, pts, p, lift, target, 100.0)
    assert cost(out) < 0.5 * cost(p)
    assert lift * out.sum() == pytest.approx(target, rel=1e-6)
