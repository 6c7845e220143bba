"""One cost model (issue 21): inputs inside every range that would never finish are refused
up front, with the estimate in one line; the plans people run pass it.

Every refusal is timed in this process: it must come before any work (a few seconds at most);
each CLI case runs with a subprocess timeout (a hang guard only: the import of flexlift on a
busy machine takes its time), so a regression (work started) fails instead of hanging."""

import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

import flexlift
from flexlift import load_scenario
from flexlift.errors import InputError
from flexlift.scenario import cost as C
from flexlift.scenario import parse_scenario
from flexlift.scenario.cost import MAX_BAGS, estimate, refusal

SRC = str(Path(flexlift.__file__).resolve().parents[1])
#: a refusal is quick: the parse of the file, no modes, no plan [s]
QUICK_S = 5.0


def refused_quickly(path, *needles) -> str:
    """``path`` loaded here: refused (InputError naming ``needles``) within QUICK_S."""
    t0 = time.monotonic()
    with pytest.raises(InputError) as exc:
        load_scenario(path)
    took = time.monotonic() - t0
    assert took < QUICK_S, took
    for n in needles:
        assert n in str(exc.value), str(exc.value)
    return str(exc.value)


def flexlift_cli(*args, timeout=180.0, cwd=None):
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "flexlift", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd,
                          env={"PYTHONPATH": SRC, "MPLBACKEND": "Agg", "PATH": "/usr/bin:/bin"})
    return proc, time.monotonic() - t0


def one_line(proc, *needles) -> str:
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]


def _pipeline_data() -> dict:
    return yaml.safe_load((Path(flexlift.__file__).parent / "scenarios" / "pipeline.yaml")
                          .read_text())


# ------------------------------------------------------------------ refused before any work
def test_a_thousand_bag_entries_of_a_thousand_bags_each_are_refused_at_once(tmp_path):
    bags = [{"name": f"b{k}", "kind": "external", "x_m": 1.0 + 0.07 * k, "count": 1000}
            for k in range(1000)]
    f = tmp_path / "bags.yaml"
    f.write_text(yaml.safe_dump({"name": "many", "lift": {"bags": bags}}))
    refused_quickly(f, "1,000,000 bags", f"at most {MAX_BAGS:,} bags after clusters")
    one_line(flexlift_cli("simulate", str(f))[0], "1,000,000 bags", "estimated")


def test_twenty_thousand_elements_with_a_thousand_retained_modes_are_refused_at_once(tmp_path):
    f = tmp_path / "deep.yaml"
    f.write_text(yaml.safe_dump({"name": "deep", "hull": {"elements": 20000},
                                 "simulation": {"retained_flexible_modes": 1000}}))
    refused_quickly(f, "20,000 elements", "1,012 modes", "at most 10 min", "estimated")
    proc, _ = flexlift_cli("run", str(f), "--out", str(tmp_path / "o"))
    one_line(proc, "20,000 elements", "1,012 modes", "at most 10 min", "estimated")
    assert not (tmp_path / "o").exists()


def test_a_pipe_of_200_lift_points_of_10_bags_is_refused_at_once(tmp_path):
    data = _pipeline_data()
    data["pipe"]["lift_points"] = {"spacing_m": 5.0, "count": 10}  # 200 points x 10
    data["control"].pop("sequence")
    f = tmp_path / "pipe.yaml"
    f.write_text(yaml.safe_dump(data))
    refused_quickly(f, "2,000 bags", "estimated")
    one_line(flexlift_cli("simulate", str(f))[0], "2,000 bags", "estimated")


def test_the_refusal_is_the_schema_s_for_every_way_in():
    tanker = load_scenario("tanker")
    with pytest.raises(InputError, match="too large .*20,000 elements"):
        tanker.with_changes(**{"hull.elements": 20000,
                               "simulation.retained_flexible_modes": 1000})
    with pytest.raises(InputError, match="at most 2,000 bags after clusters"):
        parse_scenario({"name": "x", "lift": {"bags": [
            {"name": "a", "kind": "external", "x_m": 30.0, "count": 1000},
            {"name": "b", "kind": "external", "x_m": 50.0, "count": 1000},
            {"name": "c", "kind": "external", "x_m": 60.0}]}})  # 2,001 bags in three entries


def test_the_plan_sizer_counts_the_automatic_layout_with_the_same_model(tanker):
    """The automatic layout's bags are counted where they are sized, before any is laid out
    (the schema counts the explicit ones): the same limits, the same estimate."""
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario

    sc = tanker.with_changes(**{"lift.catalogue_bag.lift_t": 0.01})  # 3,617 t / 10 kg
    assert estimate(sc).bags == pytest.approx(361_700, rel=1e-3)  # the sizer's rule, on the mass
    t0 = time.monotonic()
    with pytest.raises(InputError, match=r"the plan would need 361,\d{3} bags.*at most 2,000 bags"):
        plan_lift(sc, hull_from_scenario(sc))
    assert time.monotonic() - t0 < QUICK_S


# ------------------------------------------------------------------ what people run passes
@pytest.mark.parametrize("bag_t, bags", [(565.0, 7), (150.0, 25), (50.0, 73), (20.0, 181),
                                         (10.0, 362)])
def test_the_benchmark_plans_of_up_to_400_bags_pass(tanker, bag_t, bags):
    """Issue 24's benchmark: the tanker, balanced layout, no internal bags, catalogue bags of
    565 / 150 / 50 / 20 / 10 t (7 to 362 bags); and 400 bags counted as the sizer would."""
    sc = tanker.with_changes(**{"lift.layout": "balanced", "lift.internal_bags": 0,
                                "lift.catalogue_bag.lift_t": bag_t})
    c = estimate(sc)
    assert c.bags == bags
    assert refusal(c) is None and refusal(estimate(sc, bags=400)) is None


def test_the_built_in_pipeline_passes_at_its_maxima():
    """The pipeline as built in, with the most flexible modes ``auto`` gives (60) and ten
    bags per lift point (400 bags), and on its longest mesh (20,000 elements)."""
    p = load_scenario("pipeline")
    assert refusal(estimate(p)) is None
    data = _pipeline_data()
    data["simulation"]["retained_flexible_modes"] = C.AUTO_MODES[1]
    data["pipe"]["lift_points"]["count"] = 10
    big = parse_scenario(data)
    assert estimate(big).bags == 400 and refusal(estimate(big)) is None
    data["pipe"]["elements"] = 20000
    assert refusal(estimate(parse_scenario(data))) is None


def test_the_model_s_copies_of_the_solver_s_numbers_agree():
    from flexlift.ascent import plant
    from flexlift.stages.run import DEFAULT_CONTROLS
    from flexlift.structure import eigen, modes

    assert C.AUTO_MODES == plant.AUTO_FLEXIBLE_MODES
    assert C.PLANT_MODES == plant.MODES_FOR_CORRECTION
    assert (C.FINE_MESH_ELEMENTS, C.COARSE_STRIPS) == (plant.FINE_MESH_ELEMENTS,
                                                       2 * plant.LOAD_SEGMENTS)
    assert C.DENSE_MAX_DOF == eigen.DENSE_MAX_DOF
    assert C.ALL_MODES_ELEMENTS == modes.LARGE_MODEL_ELEMENTS
    assert C.RUN_CONTROLS == len(DEFAULT_CONTROLS)


def test_the_estimate_grows_with_what_the_work_grows_with(tanker):
    base = estimate(tanker)
    assert estimate(tanker, bags=100).run_s > base.run_s
    assert estimate(tanker, duration=12000).run_s > base.run_s
    assert estimate(tanker.with_changes(**{"hull.elements": 200})).run_s > base.run_s
    more = tanker.with_changes(**{"simulation.retained_flexible_modes": 8})
    assert estimate(more).modes == 2 + 8 + 10 > base.modes == 24 or estimate(more).run_s > 0
    assert estimate(more).run_s >= base.run_s


# ------------------------------------------------------------------ the options
@pytest.mark.parametrize("args, needles", [
    (["modes", "--elements", "1000000"], ["--elements", "1000000", "less than or equal to 20000",
                                          "hull.elements"]),
    (["modes", "--elements", "20000", "--modes", "40002"], ["--elements/--modes", "estimated"]),
    (["simulate", "--duration", "1e300"], ["--duration", "less than or equal to 1000000"]),
    (["simulate", "--duration", "3e7"], ["--duration", "less than or equal to 1000000"]),
    (["simulate", "--duration", "5e5"], ["--duration", "at most 100,000"]),
    (["simulate", "--duration", "nan"], ["--duration", "finite"]),
    (["sweep", "SPEC", "--workers", "1000000000000000000000000000000"], ["--workers",
                                                                         "less than or equal"]),
    (["sweep", "SPEC", "--workers", "100000"], ["--workers", "per core"]),
    (["sweep", "SPEC", "--dask-local", "1000"], ["--dask-local", "per core"]),
    (["fuzzy", "--grid", "1000000", "--json"], ["--grid", "less than or equal to 1001"]),
])
def test_an_option_is_its_key_same_range_same_message(args, needles, tmp_path):
    spec = tmp_path / "s.yaml"
    spec.write_text("base: tanker\ncontrol: [coordinated]\ngrid: {hydro.drag_coefficient: [1.1]}\n")
    args = [str(spec) if a == "SPEC" else a for a in args]
    one_line(flexlift_cli(*args, cwd=tmp_path)[0], *needles)


def test_the_file_key_and_the_option_say_the_same(tmp_path):
    f = tmp_path / "long.yaml"
    f.write_text("name: long\nsimulation: {duration_s: 3.0e+7}\n")
    from_file = one_line(flexlift_cli("simulate", str(f))[0])
    from_option = one_line(flexlift_cli("simulate", "--duration", "3e7")[0])
    msg = "Input should be less than or equal to 1000000"
    assert msg in from_file and msg in from_option


def test_workers_are_capped_at_four_per_core():
    from flexlift.sweep.executors import WORKERS_PER_CORE, local_cores, make_engine, max_workers

    assert max_workers() == WORKERS_PER_CORE * local_cores()
    with pytest.raises(InputError, match="per core"):
        make_engine(workers=max_workers() + 1)
    with pytest.raises(InputError, match="per core"):
        make_engine(dask_local=10**30)


def test_a_sweep_beyond_ten_minutes_needs_yes(tmp_path):
    from flexlift.sweep import load_spec
    from flexlift.sweep.run import estimate_sweep

    spec = tmp_path / "s.yaml"
    spec.write_text("base: tanker\ncontrol: [coordinated, decentralized]\n"
                    "monte_carlo: {samples: 5000, seed: 1,\n"
                    "  vary: {hydro.drag_coefficient: {dist: uniform, low: 1.0, high: 1.3}}}\n")
    t0 = time.monotonic()
    per, total = estimate_sweep(load_spec(spec), workers=1)
    assert time.monotonic() - t0 < QUICK_S
    assert total == pytest.approx(5000 * per) and total > C.MAX_SECONDS
    proc, _ = flexlift_cli("sweep", str(spec), "--workers", "1", "--out", str(tmp_path / "o"))
    one_line(proc, "5,000 cases", "estimated", "--yes")
    assert not (tmp_path / "o").exists()
