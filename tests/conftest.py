import matplotlib
import pytest

matplotlib.use("Agg")


@pytest.fixture(scope="session")
def tanker():
    from flexlift import load_scenario

    return load_scenario("tanker")


@pytest.fixture(scope="session")
def tanker_hull(tanker):
    from flexlift.structure.hull import hull_from_scenario

    return hull_from_scenario(tanker)


@pytest.fixture(scope="session")
def tanker_modes(tanker_hull):
    from flexlift.structure.modes import compute_modes

    return compute_modes(tanker_hull)


@pytest.fixture(scope="session")
def tanker_plan(tanker, tanker_hull, tanker_modes):
    from flexlift.loads.liftplan import plan_lift

    return plan_lift(tanker, tanker_hull, tanker_modes)
