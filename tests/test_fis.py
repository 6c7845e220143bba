"""MATLAB .fis import/export: MATLAB's own tipper example, exact round trips, bad files."""

import math

import numpy as np
import pytest

from flexlift.errors import InputError
from flexlift.fuzzy.fis import from_fis_text, read_fis, to_fis_text, write_fis
from flexlift.fuzzy.rulebase import fill_fis, supervisor_fis
from flexlift.fuzzy.system import FIS, MF, Rule, Variable

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


def test_comments_blank_lines_spaces_and_the_old_header_read_as_matlab_reads_them():
    body = TIPPER.replace("Version=2.0\n", "")  # the header before Fuzzy Logic Toolbox 2.0
    text = "% $Revision: 1.1 $\n# another tool's comment\n\n" + body.replace(
        "[Input2]", "% a comment inside the file\n\n[Input2]").replace(
        "NumMFs=3", "  NumMFs = 3   % trailing comment").replace(
        "MF1='rancid':'trapmf',[0 0 1 3]", "MF1 = 'rancid' : 'trapmf' , [0, 0, 1, 3]").replace(
        "1 1, 1 (1) : 2", "1.000 1.000 , 1.000 (1.000) : 2")
    assert from_fis_text(text) == from_fis_text(TIPPER)
    assert from_fis_text(TIPPER.replace("Version=2.0", "Version=6.0")) == from_fis_text(TIPPER)


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


def test_sugeno_and_several_outputs_round_trip(tmp_path):
    sets = (MF("lo", "zmf", (0.1, 0.6)), MF("mid", "pimf", (0.1, 0.4, 0.5, 0.9)),
            MF("hi", "linsmf", (0.4, 1.0)), MF("d", "dsigmf", (9, 0.2, 9, 0.8)),
            MF("p", "psigmf", (9, 0.2, -9, 0.8)), MF("s", "smf", (0.3, 0.7)),
            MF("z", "linzmf", (0.0, 0.5)))
    x, v = Variable("x", (0, 1), sets), Variable("v", (-2, 2), ())
    f = Variable("f", (-5, 5), (MF("c", "constant", (1.5,)), MF("l", "linear", (2, -1, 0.25))))
    g = Variable("g", (0, 9), (MF("k", "constant", (7,)),))
    rules = (Rule((0, None), (0, 0)), Rule((6, None), (1, None), weight=0.5, negated=(True, False)),
             Rule((2, None), (None, 0), connective="or"))
    for defuzz in ("wtaver", "wtsum"):
        fis = FIS("s", (x, v), (f, g), rules, kind="sugeno", defuzzification=defuzz)
        text = to_fis_text(fis)
        assert "Type='sugeno'" in text and "NumOutputs=2" in text and "-7 0, 2 0 (0.5) : 1" in text
        back = read_fis(write_fis(fis, tmp_path / "s.fis"))
        assert back == fis
        q = np.random.default_rng(1).uniform([0, -2], [1, 2], (40, 2))
        np.testing.assert_array_equal(back(q), fis(q))


def _bad(old, new):
    assert old in TIPPER
    return TIPPER.replace(old, new)


@pytest.mark.parametrize(
    "text, line, match",
    [  # the bad input: not a .fis, a missing set, a range lo >= hi, a wrong count
     ("name: tanker\nwater_depth_m: 50\n", 1, "must follow a .Section. header.*starts with .System."),
     (_bad("3 2, 3 (1) : 2", "3 4, 3 (1) : 2"), 40, "input 'food' has sets 1..2.*does not exist"),
     (_bad("3 2, 3 (1) : 2", "3 2, 9 (1) : 2"), 40, "output 'tip' has sets 1..3"),
     (_bad("Range=[0 30]", "Range=[30 30]"), 31, "needs finite lo < hi"),
     (_bad("Range=[0 10]\nNumMFs=2", "Range=[10 0]\nNumMFs=2"), 24, "needs finite lo < hi"),
     (_bad("'trimf',[0 5 10]", "'trimf',[0 5]"), 33, r"trimf takes 3 parameters \[a b c\]"),
     (_bad("'gaussmf',[1.5 5]", "'gaussmf',[1.5 5 2]"), 19, r"gaussmf takes 2 parameters"),
     # what flexlift cannot know: custom operators and functions, named with their line
     (_bad("AndMethod='min'", "AndMethod='einstein_product'"), 8, "'einstein_product' is a custom AND"),
     (_bad("DefuzzMethod='centroid'", "DefuzzMethod='mydefuzz'"), 12, "custom defuzzification"),
     (_bad("DefuzzMethod='centroid'", "DefuzzMethod='wtaver'"), 12, "is for Type='sugeno'"),
     (_bad("'gaussmf',[1.5 5]", "'cosinemf',[1 5]"), 19, "'cosinemf' is a custom function"),
     (_bad("Type='mamdani'", "Type='tsukamoto'"), 3, "Type='mamdani' or Type='sugeno'"),
     (_bad("2 0, 2 (1) : 1", "2.3 0, 2 (1) : 1"), 39, "fractional: a hedge"),
     # other malformed lines
     (_bad("Type='mamdani'", "Type='sugeno'").replace("'centroid'", "'wtaver'"), 33, "a Sugeno output set is 'constant'"),
     (_bad("AndMethod='min'", "AndMethod='mean'"), 8, "AND method"),
     (_bad("'trimf',[0 5 10]", "'trimf',[10 5 0]"), 33, "a <= b <= c"),
     (_bad("NumRules=3", "NumRules=4"), 7, "has 3 rules"),
     (_bad("NumMFs=2", "NumMFs=3"), 25, "has 2 MF lines"),
     (_bad("2 0, 2 (1) : 1", "2 0 2 1"), 39, "rules are written"),
     (_bad("2 0, 2 (1) : 1", "2 0, 2 (1) : 3"), 39, "connective 1"),
     (_bad("2 0, 2 (1) : 1", "0 0, 2 (1) : 1"), 39, "at least one input set"),
     (_bad("Range=[0 30]", "Range=[0 x]"), 31, "numbers"),
     (_bad("Name='tip'", "Nmae='tip'"), 30, r"\[Output1\] keys: Name, Range"),
     (_bad("1 1, 1 (1) : 2", "1 1, 1 (1.5) : 2"), 38, "weight")],
)
def test_bad_files_raise_one_line_naming_file_and_line(text, line, match):
    with pytest.raises(InputError, match=match) as exc:
        from_fis_text(text, source="bad.fis")
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith(f"bad.fis line {line}:")


@pytest.mark.parametrize(
    "old, new, match",
    [("[Output1]", "[Output2]", r"no \[Output1\] section"),
     ("[Rules]", "[Rulez]", r"no \[Rules\] section"),
     ("NumOutputs=1\n", "", "needs NumOutputs")],
)
def test_missing_parts_name_the_file(old, new, match):
    with pytest.raises(InputError, match=match) as exc:
        from_fis_text(_bad(old, new), source="bad.fis")
    assert str(exc.value).startswith("bad.fis") and "\n" not in str(exc.value)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        read_fis(tmp_path / "nope.fis")


def test_parameter_arithmetic_as_matlab_evaluates_it():
    fis = from_fis_text(_bad("Range=[0 10]\nNumMFs=2", "Range=[-pi/4 2*pi+1]\nNumMFs=2"))
    assert fis.inputs[1].range == (-math.pi / 4, 2 * math.pi + 1)
    with pytest.raises(InputError, match="line 24"):
        from_fis_text(_bad("Range=[0 10]\nNumMFs=2", "Range=[0 exp(1)]\nNumMFs=2"))


def test_to_skfuzzy_refuses_what_scikit_fuzzy_cannot_mirror():
    from flexlift.fuzzy.fis import to_skfuzzy
    from flexlift.fuzzy.rulebase import fill_fis, supervisor_fis

    sim, out = to_skfuzzy(supervisor_fis())
    sim.input["e"], sim.input["edot"] = 0.3, -0.2
    sim.compute()
    assert abs(sim.output[out.label] - supervisor_fis(defuzzification="centroid_trapz")((0.3, -0.2))) < 1e-3
    with pytest.raises(InputError, match="Gaussian sets only"):
        to_skfuzzy(fill_fis().fis)  # triangular sets
