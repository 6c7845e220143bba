"""MATLAB .fis import/export: MATLAB's own tipper example, exact round trips, bad files."""

import numpy as np
import pytest

from flexlift.errors import InputError
from flexlift.fis import from_fis_text, read_fis, to_fis_text, write_fis
from flexlift.fuzzy import FIS, MF, Rule, Variable
from flexlift.rulebase import fill_fis, supervisor_fis

# MATLAB's shipped example tipper.fis, as MATLAB writes it
TIPPER = """[System]
Name='tipper'
Type='mamdani'
Version=2.0
NumInputs=2
NumOutputs=1
NumRules=3
AndMethod='min'
OrMethod='max'
ImpMethod='min'
AggMethod='max'
DefuzzMethod='centroid'

[Input1]
Name='service'
Range=[0 10]
NumMFs=3
MF1='poor':'gaussmf',[1.5 0]
MF2='good':'gaussmf',[1.5 5]
MF3='excellent':'gaussmf',[1.5 10]

[Input2]
Name='food'
Range=[0 10]
NumMFs=2
MF1='rancid':'trapmf',[0 0 1 3]
MF2='delicious':'trapmf',[7 9 10 10]

[Output1]
Name='tip'
Range=[0 30]
NumMFs=3
MF1='cheap':'trimf',[0 5 10]
MF2='average':'trimf',[10 15 20]
MF3='generous':'trimf',[20 25 30]

[Rules]
1 1, 1 (1) : 2
2 0, 2 (1) : 1
3 2, 3 (1) : 2
"""


def test_tipper_matches_matlab_evalfis():
    fis = from_fis_text(TIPPER)
    assert [v.name for v in fis.inputs] == ["service", "food"] and fis.output.range == (0, 30)
    assert fis.rules[1] == Rule((1, None), 1)  # "2 0, 2 (1) : 1": don't care on food
    assert fis.rules[0].connective == "or"
    # MATLAB documentation of evalfis / the Fuzzy Logic Toolbox getting-started example
    u = fis(np.array([[2, 1], [4, 5], [7, 8], [1, 2]]))
    np.testing.assert_allclose(u, [7.0169, 14.4585, 20.3414, 5.5586], atol=5e-5)


def test_text_round_trip_is_exact():
    assert to_fis_text(from_fis_text(TIPPER)) == TIPPER


@pytest.mark.parametrize("make", [supervisor_fis, lambda: fill_fis().fis,
                                  lambda: supervisor_fis("prod", "probor", "prod", "sum", "lom")])
def test_object_round_trip_is_exact(tmp_path, make):
    fis = make()
    path = write_fis(fis, tmp_path / "x.fis")
    back = read_fis(path, resolution=fis.resolution)
    assert back == fis  # every set parameter bit for bit, every rule, every operator
    q = np.random.default_rng(0).uniform(-1, 1, (50, fis.n_inputs))
    np.testing.assert_array_equal(back(q), fis(q))


def test_every_mf_type_negation_weights_round_trip():
    x = Variable("x", (-2, 3.5), (MF("a", "gauss2mf", (0.3, -1, 0.7, 0.1)),
                                  MF("b", "gbellmf", (0.5, 2.5, 1)), MF("c", "sigmf", (-4, 2)),
                                  MF("d", "trapmf", (1, 2, 2.5, 3.5))))
    y = Variable("y", (0, 1e-3), (MF("p", "trimf", (0, 0, 1e-3)), MF("q", "gaussmf", (1e-4, 7e-4))))
    rules = (Rule((0,), 1, weight=0.3), Rule((2,), 0, negated=(True,)),
             Rule((3,), 1, connective="or", consequent_negated=True))
    fis = FIS("every type", (x,), y, rules, defuzzification="centroid_trapz")
    text = to_fis_text(fis)
    assert "-3, 1 (1) : 1" in text and "4, -2 (1) : 2" in text and "1, 2 (0.3) : 1" in text
    assert from_fis_text(text) == fis
    assert to_fis_text(from_fis_text(text)) == text


def _bad(old, new):
    assert old in TIPPER
    return TIPPER.replace(old, new)


@pytest.mark.parametrize(
    "text, match",
    [(_bad("Type='mamdani'", "Type='sugeno'"), "only Mamdani"),
     (_bad("'gaussmf',[1.5 5]", "'zmf',[1 5]"), "membership types allowed"),
     (_bad("3 2, 3 (1) : 2", "3 4, 3 (1) : 2"), "has sets 1..2"),
     (_bad("3 2, 3 (1) : 2", "3 2, 9 (1) : 2"), "output 'tip' has sets"),
     (_bad("NumOutputs=1", "NumOutputs=2"), "only one output"),
     (_bad("AndMethod='min'", "AndMethod='mean'"), "AndMethod allowed"),
     (_bad("'trimf',[0 5 10]", "'trimf',[10 5 0]"), "a <= b <= c"),
     (_bad("NumRules=3", "NumRules=4"), "has 3 rules"),
     (_bad("[Output1]", "[Output2]"), r"no \[Output1\]"),
     (_bad("2 0, 2 (1) : 1", "2 0 2 1"), "rules are written"),
     (_bad("Range=[0 30]", "Range=[0 x]"), "numbers"),
     ("hello", "must follow a"),
     (_bad("1 1, 1 (1) : 2", "1 1, 1 (1.5) : 2"), "weight")],
)
def test_bad_files_raise_one_line(text, match):
    with pytest.raises(InputError, match=match) as exc:
        from_fis_text(text, source="bad.fis")
    assert "\n" not in str(exc.value) and "bad.fis" in str(exc.value)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="readable"):
        read_fis(tmp_path / "nope.fis")


def test_to_skfuzzy_refuses_what_scikit_fuzzy_cannot_mirror():
    from flexlift.fis import to_skfuzzy
    from flexlift.rulebase import fill_fis, supervisor_fis

    sim, out = to_skfuzzy(supervisor_fis())
    sim.input["e"], sim.input["edot"] = 0.3, -0.2
    sim.compute()
    assert abs(sim.output[out.label] - supervisor_fis(defuzzification="centroid_trapz")((0.3, -0.2))) < 1e-3
    with pytest.raises(InputError, match="Gaussian sets only"):
        to_skfuzzy(fill_fis().fis)  # triangular sets
