"""The reduction stage runs once per distinct bag model (kind and position), not once per bag:
bags of one cluster share the model, with the same numbers as reducing each on its own."""

import pytest

from flexlift.loads.liftplan import plan_lift
from flexlift.stages.reduce import bag_summary, model_key, run_stage
from flexlift.structure.hull import hull_from_scenario
from flexlift.structure.modes import compute_modes


@pytest.fixture(scope="module")
def clustered(tanker):
    """The tanker on 50 t catalogue bags, balanced: 73 bags at 10 lift points."""
    return tanker.with_changes(**{"lift.layout": "balanced", "lift.internal_bags": 0,
                                  "lift.catalogue_bag.lift_t": 50.0})


def test_one_reduction_per_lift_point_same_numbers_as_each_bag(clustered):
    res = run_stage(clustered, None)
    hull = hull_from_scenario(clustered)
    modes = compute_modes(hull)
    plan = plan_lift(clustered, hull, modes)
    points = plan.lift_points()
    assert len(plan.bags) == 73 and len(points) == 10
    assert res.summary["distinct_models"] == len(points)
    assert set(res.summary["bags"]) == {b.name for b in plan.bags}
    # a whole cluster, its neighbour's first bag and the lone bag at the bow: reduced on their own
    names = points[1][1] + [points[2][1][0], points[-1][1][0]]
    for name in names:
        own, *_ = bag_summary(clustered, modes, plan.bag(name), 2, None, plan.bags)
        assert res.summary["bags"][name] == own, name
    assert len({model_key(plan.bag(n)) for n in names}) == 3


def test_worst_row_names_the_bag_of_the_largest_error(clustered):
    res = run_stage(clustered, None)
    worst, every, _ = res.tables
    assert len(every.rows) == 4 * 73 and len(worst.rows) == 4
    for row in worst.rows:
        errs = [(r[5], r[0]) for r in every.rows if r[2] == row[0]]
        v, who = max(errs, key=lambda p: abs(p[0]))
        assert row[3] == v and res.summary["bags"][row[4]]["methods"][row[0]]["dc_error_pct"] == v
