"""The dump valve each bag purges through in the run (scenario/valves.py,
docs/theory/gas.md#dump-valves): the user's ``gas.purge_rate_max_m3_s``, else the catalogue
bag's ``dump_valve_m3_s``, else the assumed 2 m3/s; internal bags and the paper's tanker keep
``gas.purge_rate_max_m3_s``.

The runs use tests/data/trawler.yaml without its bag choice: flexlift gives it the catalogue's
open_parachute_50t, whose generic valve passes 0.407 m3/s (a full bag's 48.8 m3 in 120 s).
"""

from pathlib import Path

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.ascent.arrangement import dump_valve_check
from flexlift.ascent.plant import coupled_plant
from flexlift.control.profile import valve_profile
from flexlift.scenario.basis import design_basis
from flexlift.scenario.valves import external_valve
from flexlift.sweep.contingency.margin import scale_changes

TRAWLER = Path(__file__).parent / "data" / "trawler.yaml"
VALVE = 0.407  # [m3/s] open_parachute_50t's generic dump valve (flexlift/data/bags.yaml)
ROW = "dump valve of each external bag, in the run (fully open, bag full)"


def _wreck(tmp_path, extra: str = "") -> Path:
    """The trawler without its bag choice (flexlift picks one), ``extra`` YAML appended."""
    text = "".join(line for line in TRAWLER.read_text().splitlines(keepends=True)
                   if "catalogue_bag" not in line)
    path = tmp_path / "wreck.yaml"
    path.write_text(text + extra)
    return path


def _purged(result) -> np.ndarray:
    """The purge flow [m3/s at local pressure] of every bag and record: fill minus net flow."""
    ds = result.dataset
    return (ds["fill_rate"] - ds["net_flow"]).values


@pytest.fixture(scope="module")
def catalogue(tmp_path_factory):
    return load_scenario(_wreck(tmp_path_factory.mktemp("catalogue")))


@pytest.fixture(scope="module")
def user(tmp_path_factory):
    return load_scenario(_wreck(tmp_path_factory.mktemp("user"),
                                "gas:\n  purge_rate_max_m3_s: 2.0\n"))


def test_a_catalogue_bags_run_purges_at_most_its_dump_valve(catalogue):
    """The plant's external bags take the catalogue's valve; the run's purge flow, read from
    the result, never exceeds it, and the controller does open the valves (over half of it)."""
    assert catalogue.lift.catalogue_bag.model == "open_parachute_50t"
    assert external_valve(catalogue) == (VALVE, "catalogue", "lift.catalogue_bag.dump_valve_m3_s")
    plant = coupled_plant(catalogue)
    assert np.all(plant.bags.purge_max[plant.external] == VALVE)
    r = simulate(catalogue)
    assert all(r.criteria.values()), r.criteria  # a fifth of the assumed valve is enough here
    q = np.nanmax(_purged(r))
    assert 0.5 * VALVE < q <= VALVE * (1 + 1e-9)


def test_the_users_purge_rate_wins_over_the_catalogue(user):
    """``gas.purge_rate_max_m3_s`` given in the file: every bag takes it, and the same run then
    purges more than the catalogue's valve could pass."""
    assert external_valve(user) == (2.0, "user", "gas.purge_rate_max_m3_s")
    plant = coupled_plant(user)
    assert np.all(plant.bags.purge_max == 2.0)
    assert np.nanmax(_purged(simulate(user))) > 2.0 * VALVE


def test_the_design_basis_names_the_valve_and_its_source(catalogue, user):
    rows = {r["item"]: r for r in design_basis(catalogue)}
    assert rows[ROW]["value"] == f"{VALVE:g} m3/s" and rows[ROW]["source"] == "catalogue"
    assert "gas.purge_rate_max_m3_s" not in rows  # shown once, in the valve's row
    rows = {r["item"]: r for r in design_basis(user)}
    assert rows[ROW]["value"] == "2 m3/s" and rows[ROW]["source"] == "user"
    tanker = {r["item"]: r for r in design_basis(load_scenario("tanker"))}
    assert tanker[ROW]["value"] == "2 m3/s" and tanker[ROW]["source"] == "paper"
    trawler = {r["item"]: r for r in design_basis(load_scenario(TRAWLER))}  # no valve listed
    assert trawler[ROW]["value"] == "2 m3/s" and trawler[ROW]["source"] == "assumed"


def test_the_tanker_and_internal_bags_keep_the_scenarios_purge_rate():
    """The paper's cylinder has no catalogue valve: the tanker's seven bags purge through
    gas.purge_rate_max_m3_s as before (its published numbers: tests/test_run.py); a catalogue
    bag's internal bags too."""
    tanker = load_scenario("tanker")
    assert external_valve(tanker).source == "paper"
    assert np.all(coupled_plant(tanker).bags.purge_max == tanker.gas.purge_rate_max_m3_s)
    mixed = tanker.with_changes(**{"lift.catalogue_bag": {"model": "open_parachute_50t"},
                                   "lift.layout": "balanced", "gas.purge_rate_max_m3_s": 2.0})
    plant = coupled_plant(mixed)
    assert plant.external.any() and not plant.external.all()
    assert np.all(plant.bags.purge_max[plant.external] == VALVE)
    assert np.all(plant.bags.purge_max[~plant.external] == 2.0)


def test_the_arrangement_check_compares_the_valve_the_run_uses(tmp_path):
    """A 10 m deep target: a full 50 t bag expands at 0.476 m3/s at 0.2 m/s; the catalogue's
    0.407 m3/s valve trips the check, the user's 0.6 m3/s passes it, named as the user's."""
    shallow = "control:\n  target_height_m: 110.0\n"
    text = _wreck(tmp_path).read_text().replace("control:\n  target_height_m: 60.0\n", "")
    (tmp_path / "cat.yaml").write_text(text + shallow)
    (tmp_path / "user.yaml").write_text(text + shallow + "gas:\n  purge_rate_max_m3_s: 0.6\n")
    cat, usr = load_scenario(tmp_path / "cat.yaml"), load_scenario(tmp_path / "user.yaml")
    check = dump_valve_check(cat, coupled_plant(cat).plan)
    assert not check.ok and "passes 0.407 m3/s" in check.message
    check = dump_valve_check(usr, coupled_plant(usr).plan)
    assert check.ok and "the user's dump valve (gas.purge_rate_max_m3_s) passes 0.6 m3/s" in \
        check.message


def test_the_planned_profile_takes_each_bags_own_valve():
    """Two bags, the fuller one with a quarter of the other's valve: the planned ascent is that
    bag's alone (its limit, q sqrt(V / V_max) / V, is the tighter: 0.1 m3/s on 40 m3 against
    0.4 m3/s on 20 m3), and not the one the valves swapped would give."""
    args = dict(target=60.0, speed=0.2, accel=0.002, eta=0.8, water_depth=70.0,
                p_atm=101325.0, rho_g=1025.0 * 9.81)
    both = valve_profile(volume=[40.0, 20.0], capacity=[48.8, 48.8], purge_max=[0.1, 0.4], **args)
    tight = valve_profile(volume=[40.0], capacity=[48.8], purge_max=[0.1], **args)
    swapped = valve_profile(volume=[40.0, 20.0], capacity=[48.8, 48.8], purge_max=[0.4, 0.1], **args)
    assert tight is not None and both.duration == tight.duration
    assert swapped.duration != pytest.approx(both.duration, rel=1e-3)


def test_a_dump_valve_margin_scales_the_valve_the_run_uses(catalogue):
    """A contingency's dump-valve margin scales the catalogue's valve when it governs, the
    scenario's purge rate otherwise."""
    assert scale_changes("dump_valve", 1.3, catalogue) == {
        "lift.catalogue_bag.dump_valve_m3_s": pytest.approx(1.3 * VALVE)}
    tanker = load_scenario("tanker")
    assert scale_changes("dump_valve", 1.3, tanker) == {
        "gas.purge_rate_max_m3_s": pytest.approx(2.6)}


def test_a_purge_rate_given_by_with_changes_is_the_users(catalogue):
    """``with_changes`` (the API, a sweep's case) gives the key: it is no longer listed as
    assumed, and it wins over the catalogue's valve as a file's would."""
    given = catalogue.with_changes(**{"gas.purge_rate_max_m3_s": 0.5})
    assert "gas.purge_rate_max_m3_s" not in given.defaulted
    assert external_valve(given) == (0.5, "user", "gas.purge_rate_max_m3_s")
    assert "hull.modal_damping" in given.defaulted  # the others stay assumed
