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


@pytest.fixture(scope="session")
def tanker_run_folder(tmp_path_factory):
    """``flexlift run`` on the built-in tanker with two figure processes, once for the tests
    that only read its folder (test_run's, and test_figures' against a run drawn in one
    process): the folder, the exit code, and the figures drawn in the main process instead
    of a figure process (its fallback: none expected)."""
    from flexlift.cli import main
    from flexlift.output.plots import _style

    out = tmp_path_factory.mktemp("run") / "tanker"
    fallbacks = []
    draw_here = _style._draw_here

    def recording(plot, args, kwargs, path, why):
        fallbacks.append(f"{path.name}: {why}")
        draw_here(plot, args, kwargs, path, why)

    with pytest.MonkeyPatch.context() as mp:
        mp.setenv(_style.PROCESSES_ENV, "2")
        mp.setattr(_style, "_draw_here", recording)
        rc = main(["run", "--out", str(out), "--quiet"])
    return out, rc, fallbacks
