"""A staged lift (control.sequence, docs/theory/statics.md#staged): the sequence, the plant's stretches, the
controllers' start times, and the built-in pipeline peeled off the seabed stage by stage."""

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.ascent.checks import breakout_check
from flexlift.ascent.mechanics import contact_matrices, update_contact_matrices
from flexlift.ascent.plant import coupled_plant, retained_flexible
from flexlift.control.build import controller_for, fuzzy_maps
from flexlift.control.controller import sample
from flexlift.control.sequence import stage_groups, start_times
from flexlift.errors import InputError


@pytest.fixture(scope="module")
def line():
    return load_scenario("pipeline")


@pytest.fixture(scope="module")
def line_runs(line):
    return {m: simulate(line, control=m) for m in ("decentralized", "coordinated")}


def _groups(line, names):
    return [[names[i] for i in g] for g in stage_groups(line, names, np.arange(len(names)) * 25.0,
                                                       [True] * len(names))]


# ------------------------------------------------------------------------- the sequence
def test_groups_by_position_from_either_end(line):
    names = [f"B{i:02d}" for i in range(1, 8)]
    start = line.with_changes(**{"control.sequence": {"group_size": 3, "delay_s": 10.0}})
    assert _groups(start, names) == [names[0:3], names[3:6], names[6:]]
    end = line.with_changes(**{"control.sequence": {"from_end": "end", "group_size": 2}})
    assert _groups(end, names) == [["B07", "B06"], ["B05", "B04"], ["B03", "B02"], ["B01"]]
    t = start_times(start, names, np.arange(7) * 25.0, [True] * 7)
    assert list(t) == [0, 0, 0, 10, 10, 10, 20]
    assert list(start_times(line.with_changes(**{"control.sequence": None}), names,
                            np.arange(7) * 25.0, [True] * 7)) == [0] * 7


@pytest.mark.parametrize("groups, key, needle", [
    ([["B01", "B99"]], "control.sequence.groups[0][1]", "not a bag of this plan"),
    ([["B01"], ["B01"]], "control.sequence.groups[1][0]", "already in group 0"),
    ([["B01", "B02"]], "control.sequence.groups", "missing: B03"),
])
def test_a_sequence_naming_unknown_twice_or_missing_bags_is_refused(line, groups, key, needle):
    sc = line.with_changes(**{"control.sequence": {"groups": groups}})
    with pytest.raises(InputError) as e:
        stage_groups(sc, ["B01", "B02", "B03"], [0.0, 25.0, 50.0], [True] * 3)
    assert e.value.field == key and needle in str(e.value)


def test_an_internal_bag_in_a_sequence_is_refused(tanker):
    names = [b.name for b in coupled_plant(tanker).plan.bags]
    sc = tanker.with_changes(**{"control.sequence": {"groups": [names]}})
    with pytest.raises(InputError, match="an internal bag"):
        coupled_plant(sc)


# ------------------------------------------------------------------------- the plant
def test_each_stage_has_its_stretch_its_suction_and_its_weight(line):
    P = coupled_plant(line)
    assert P.seabed.ng == 10
    assert np.all(np.diff(P.strips.group) >= 0)  # contiguous stretches from KP 0
    assert P.seabed.H0.sum() == pytest.approx((line.lift.breakout_factor - 1) * P.wet_weight, rel=1e-12)
    assert P.seabed.group_weight.sum() == pytest.approx(P.wet_weight, rel=1e-12)
    assert P.seabed.H0 == pytest.approx(np.full(10, P.seabed.H0.sum() / 10), rel=1e-9)  # a uniform line
    # each stretch's bags hold its weight at the start: the line rests neutral stage by stage
    lift = np.bincount(P.bags.group, P.neutral_volume * P.bags.rho_g, P.seabed.ng)
    assert lift == pytest.approx(P.seabed.group_weight, rel=1e-12)
    # the hold per unit H of its group integrates to 1 over each stretch
    per = np.bincount(P.strips.group, P.strips.weight * P.strips.hold, P.seabed.ng)
    assert per == pytest.approx(np.ones(10), rel=1e-12)


def test_no_sequence_is_one_group(tanker):
    a = coupled_plant(tanker)
    assert a.seabed.ng == 1 and not a.strips.group.any() and not a.bags.group.any()


def test_retained_modes_auto_resolves_the_lift_point_spacing(line, tanker):
    P = coupled_plant(line)
    assert retained_flexible(line, P.hull, P.plan) == 40  # 1 km / 25 m
    assert P.modal.nr == 42
    assert retained_flexible(tanker, None, None) == 3  # a number is kept
    few = line.with_changes(**{"pipe.lift_points": {"spacing_m": 400.0}})
    Pf = coupled_plant(few)
    assert retained_flexible(few, Pf.hull, Pf.plan) == 3  # never fewer than 3


def test_contact_springs_updated_strip_by_strip_equal_a_rebuild(line):
    a = coupled_plant(line.with_changes(**{"pipe.elements": 100}))
    rng = np.random.default_rng(1)
    last = rng.random(a.strips.ns) < 0.5
    stiff, damp = np.zeros((a.modal.nr, a.modal.nr)), np.zeros((a.modal.nr, a.modal.nr))
    contact_matrices(a.records, last, stiff, damp)
    for _ in range(20):
        now = last ^ (rng.random(a.strips.ns) < 0.05)
        update_contact_matrices(a.records, now, last, stiff, damp)
        K, C = np.zeros_like(stiff), np.zeros_like(damp)
        contact_matrices(a.records, now, K, C)
        assert np.abs(stiff - K).max() <= 1e-9 * np.abs(K).max()
        assert np.abs(damp - C).max() <= 1e-9 * np.abs(C).max()
        last = now


# ------------------------------------------------------------------------- the controllers
def _two_stages(line, mode):
    """Controllers of the line in two stages of 20 bags, 100 s apart: (C, S, first, second)."""
    sc = line.with_changes(**{"pipe.elements": 40, "control.sequence":
                              {"group_size": 20, "delay_s": 100.0}})
    table, _, fill = fuzzy_maps(sc)
    C, S = controller_for(sc, coupled_plant(sc), mode, table, fill)
    return C, S, C.start == 0.0, C.start == 100.0


def test_a_bag_is_passive_until_its_start_then_pulls_then_rises(line):
    C, S, first, second = _two_stages(line, "decentralized")
    nc = C.bags.size
    assert first.sum() == second.sum() == 20
    z, zd, V = np.zeros(nc), np.zeros(nc), C.V_neutral.copy()
    held = np.zeros(nc, dtype=bool)
    sample(10.0, z, zd, V, held, C, S)
    assert S.V_d[first] == pytest.approx(C.V_neutral[first] + C.V_pull[first])
    assert S.V_d[second] == pytest.approx(C.V_neutral[second])  # passive: no pull
    let_go = first.copy()  # the first stretch lets go; the second is still held
    sample(50.0, z + 0.3, zd, V, let_go, C, S)
    assert np.all(S.t_sep[first] == 50.0) and np.all(np.isnan(S.t_sep[second]))
    assert S.z0[first] == pytest.approx(0.3)
    sample(120.0, z + 0.5, zd, V, np.ones(nc, dtype=bool), C, S)  # all free, the second started
    assert np.all(S.t_sep[second] == 120.0) and S.z0[second] == pytest.approx(0.5)
    assert np.all(S.t_sep[first] == 50.0)  # the first keeps its own reference


def test_coordinated_stages_start_from_their_own_mean_height(line):
    C, S, first, second = _two_stages(line, "coordinated")
    nc = C.bags.size
    z = np.linspace(0.0, 1.0, nc)
    sample(50.0, z, np.zeros(nc), C.V_neutral.copy(), first, C, S)
    assert S.z0[first] == pytest.approx(np.full(20, z[first].mean()))
    z2 = z + 0.2
    sample(100.0, z2, np.zeros(nc), C.V_neutral.copy(), np.ones(nc, dtype=bool), C, S)
    assert S.z0[second] == pytest.approx(np.full(20, z2[second].mean()))
    assert S.z0[first] == pytest.approx(np.full(20, z[first].mean()))  # kept


# ------------------------------------------------------------------------- the built-in line
@pytest.mark.parametrize("mode", ["decentralized", "coordinated"])
def test_the_builtin_pipeline_is_peeled_off_stage_by_stage(line_runs, mode):
    r = line_runs[mode]
    assert all(r.criteria.values()), r.reasons
    ds = r.dataset
    P = coupled_plant(load_scenario("pipeline"))
    stage = P.bags.group
    arrival = ds.arrival_time.values
    by_stage = [np.median(arrival[stage == k]) for k in range(10)]
    assert np.all(np.diff(by_stage) > 15.0)  # the stages arrive in turn, ~30 s apart
    # the touchdown point moves along the line from KP 0 while the line peels off
    tdp = ds.grounded_from.values
    peel = np.isfinite(tdp) & (ds.grounded_length.values < 999.0)
    assert peel.sum() >= 10 and np.all(np.diff(tdp[peel]) >= -1e-9)
    assert tdp[peel][0] < 150.0 and tdp[peel][-1] > 850.0
    assert np.all(ds.grounded_to.values[peel] > 990.0)
    # the statics close: the moment at the free end is the integration's error
    M = ds.bending_moment.values
    assert np.abs(M[:, -1]).max() < 0.01 * np.abs(M).max()
    # inside the small-deflection beam's validity, and the stress well inside the allowable
    h = r.headline
    assert 1.0 < h["max_slope_deg"] < 10.0 and not r.warnings
    assert 0.1 < h["max_utilisation"] < 1.0


def test_the_breakout_check_predicts_the_stages_separations(line, line_runs):
    c = breakout_check(line, coupled_plant(line))
    assert c.ok and "10 stages" in c.message
    first = float(c.message.split("the first at ~")[1].split(" s")[0].replace(",", ""))
    assert first == pytest.approx(line_runs["decentralized"].headline["separation_time_s"],
                                  rel=0.03)


def test_a_steep_staged_lift_is_warned_with_where_and_when(line):
    r = simulate(line.with_changes(**{"control.sequence.delay_s": 150.0}), control="decentralized",
                 duration=1500.0)
    assert r.headline["max_slope_deg"] > 10.0
    (w,) = r.warnings
    assert "passed 10 deg from" in w and f"x = {r.headline['max_slope_x_m']:.0f} m" in w
    assert "small-deflection" in w


#: the built-in line's headline numbers (docs/guide/pipelines.md, "The built-in line's ascent")
LINE_HEADLINE = {
    "decentralized": {"separation_time_s": 648.3, "max_ascent_velocity_ms": 0.2256,
                      "max_bending_moment_MNm": 0.365, "max_utilisation": 0.386,
                      "max_slope_deg": 4.63, "arrival_spread_s": 271.0},
    "coordinated": {"separation_time_s": 648.3, "max_ascent_velocity_ms": 0.3403,
                    "max_bending_moment_MNm": 0.366, "max_utilisation": 0.387,
                    "max_slope_deg": 4.60, "arrival_spread_s": 270.8},
}


@pytest.mark.parametrize("mode", ["decentralized", "coordinated"])
def test_the_builtin_lines_headline_numbers_are_pinned(line_runs, mode):
    h = line_runs[mode].headline
    for key, value in LINE_HEADLINE[mode].items():
        assert h[key] == pytest.approx(value, rel=0.02), key


def test_the_sequence_check_says_a_ship_is_too_stiff_to_peel(line, tanker):
    from flexlift.ascent.checks import plan_checks

    ok = {c.name: c for c in plan_checks(line, coupled_plant(line))}["sequence"]
    assert ok.ok and "~36 m" in ok.message and "100 m" in ok.message
    ship = tanker.with_changes(**{"control.sequence": {"group_size": 2, "delay_s": 60.0}})
    bad = {c.name: c for c in plan_checks(ship, coupled_plant(ship))}["sequence"]
    assert not bad.ok and "too stiff to peel" in bad.message
    assert "sequence" not in {c.name for c in plan_checks(tanker, coupled_plant(tanker))}


def test_slopes_are_angles_even_when_the_run_goes_wrong(tanker):
    ship = tanker.with_changes(**{"control.sequence": {"group_size": 2, "delay_s": 60.0}})
    r = simulate(ship, control="decentralized")
    assert not r.criteria["pitch"] and r.warnings
    assert 10.0 < r.headline["max_slope_deg"] <= 90.0
