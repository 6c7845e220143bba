"""Sugeno systems, several outputs, inputs beyond their range: by hand, and as MATLAB does."""

import numpy as np
import pytest

from flexlift.errors import InputError
from flexlift.fuzzy.fis import from_fis_text
from flexlift.fuzzy.system import FIS, MF, Rule, Variable

# x in [0, 1] with L = trimf(-1, 0, 1), H = trimf(0, 1, 2); z in [0, 4] (no sets: used only in
# the linear output). At x = 0.25: L = .75, H = .25.
L, H = MF("L", "trimf", (-1, 0, 1)), MF("H", "trimf", (0, 1, 2))
X = Variable("x", (0, 1), (L, H))
Z = Variable("z", (0, 4), ())
OUT = Variable("f", (-10, 10), (MF("c", "constant", (3.0,)), MF("l", "linear", (4.0, 0.5, -1.0))))


def _sugeno(rules, **kw):
    return FIS("s", (X, Z), OUT, rules, kind="sugeno", defuzzification=kw.pop("d", "wtaver"), **kw)


def test_weighted_average_and_sum_by_hand():
    rules = (Rule((0, None), 0), Rule((1, None), 1, weight=0.8))
    # rule outputs at (0.25, 2): 3 and 4 * .25 + .5 * 2 - 1 = 1; strengths .75 and .25 * .8 = .2
    f = _sugeno(rules)
    assert f([0.25, 2.0]) == pytest.approx((0.75 * 3 + 0.2 * 1) / 0.95, rel=1e-15)
    assert _sugeno(rules, d="wtsum")([0.25, 2.0]) == pytest.approx(0.75 * 3 + 0.2 * 1, rel=1e-15)
    np.testing.assert_allclose(f.firing_strengths([0.25, 2.0]), [0.75, 0.2], rtol=1e-15)
    # NOT, OR and don't care as in a Mamdani antecedent: NOT L = .25; an OR with z "any" = H
    g = _sugeno((Rule((0, None), 0, negated=(True, False)), Rule((1, None), 1, connective="or")))
    np.testing.assert_allclose(g.firing_strengths([0.25, 2.0]), [0.25, 0.25], rtol=1e-15)
    assert g([0.25, 2.0]) == pytest.approx(2.0, rel=1e-15)  # (.25 * 3 + .25 * 1) / .5


def test_no_rule_fired_is_mid_range_for_wtaver_and_wtsum():
    narrow = Variable("x", (0, 10), (MF("a", "trimf", (0, 1, 2)),))
    out = Variable("f", (-3, 5), (MF("c", "constant", (4.0,)),))
    for d in ("wtaver", "wtsum"):
        f = FIS("dead", (narrow,), out, (Rule((0,), 0),), kind="sugeno", defuzzification=d)
        assert f(9.0) == 1.0  # (-3 + 5) / 2
        assert f(1.0) == 4.0


def test_several_outputs_each_with_its_own_rules():
    # output 1 (Mamdani, [0, 1]): lo = trimf(-1, 0, 1), hi = trimf(0, 1, 2); output 2: one set
    y1 = Variable("y1", (0, 1), (MF("lo", "trimf", (-1, 0, 1)), MF("hi", "trimf", (0, 1, 2))))
    y2 = Variable("y2", (0, 8), (MF("m", "trimf", (0, 4, 8)),))
    rules = (Rule((0,), (0, None)), Rule((1,), (1, 0)))
    f = FIS("two", (X,), (y1, y2), rules, resolution=5)
    u = f(0.25)
    assert u.shape == (2,) and f(np.array([0.25, 0.5])).shape == (2, 2)
    # y1: max(min(.75, lo), min(.25, hi)) on [0 .25 .5 .75 1] = [.75 .75 .5 .25 .25]
    curve = np.array([0.75, 0.75, 0.5, 0.25, 0.25])
    assert u[0] == pytest.approx(np.dot([0, 0.25, 0.5, 0.75, 1], curve) / curve.sum(), rel=1e-14)
    assert u[1] == pytest.approx(4.0, rel=1e-14)  # only rule 2 feeds y2: a symmetric cut
    np.testing.assert_allclose(f.aggregate(0.25)[0], curve, rtol=1e-15)
    assert f.aggregate([0.25, 0.5]).shape == (2, 2, 5)
    # an output none of whose rules fires is mid-range, the other still answers
    narrow = FIS("n", (Variable("x", (0, 1), (L, MF("N", "trimf", (0.9, 0.95, 1.0)))),),
                 (y1, y2), (Rule((0,), (0, None)), Rule((1,), (None, 0))), resolution=5)
    assert narrow(0.25)[1] == 4.0 and narrow(0.25)[0] < 0.5
    with pytest.raises(InputError, match="several outputs"):
        f.output  # noqa: B018
    with pytest.raises(InputError, match="one-output"):
        FIS("t", (X, X), (y1, y2), (Rule((0, 1), (0, 0)),)).surface()


def test_out_of_range_clip_or_extrapolate_as_matlab():
    # MATLAB Answers 1909475 (2023): this system at rtRatio = 1.06985 printed "Input 1 expects a
    # value in range [0 1], but has a value of 1.06985" and "No rules fired for Output 1.
    # Defuzzified output value set to its mean range value 0.05": MATLAB evaluates the sets at
    # the value given, it does not clip.
    text = """[System]
Name='risetimeFuzzy'
Type='mamdani'
Version=2.0
NumInputs=1
NumOutputs=1
NumRules=5
AndMethod='min'
OrMethod='max'
ImpMethod='min'
AggMethod='max'
DefuzzMethod='centroid'
[Input1]
Name='rtRatio'
Range=[0 1]
NumMFs=5
MF1='eF':'trimf',[0 0 0.08]
MF2='jR':'trimf',[0.15 0.35 0.6]
MF3='eS':'trimf',[0.75 1 1]
MF4='qF':'trimf',[0.002 0.08 0.25]
MF5='qS':'trimf',[0.45 0.7 1]
[Output1]
Name='output1'
Range=[0 0.1]
NumMFs=3
MF1='lnP':'trimf',[0 0 0.015]
MF2='hP':'trimf',[0.03 0.06 0.1]
MF3='lmP':'trimf',[0.01 0.02 0.04]
[Rules]
1, 2 (1) : 1
4, 3 (1) : 1
2, 1 (1) : 1
5, 3 (1) : 1
3, 2 (1) : 1
"""
    matlab = from_fis_text(text, out_of_range="extrapolate")
    assert matlab(1.06985) == 0.05
    clipped = from_fis_text(text)
    assert clipped(1.06985) == clipped(1.0) != 0.05
    assert matlab(0.5) == clipped(0.5)
    with pytest.raises(InputError, match="NaN"):
        matlab(float("nan"))
    with pytest.raises(InputError, match="out_of_range"):
        clipped.with_options(out_of_range="wrap")


@pytest.mark.parametrize(
    "make, match",
    [(lambda: _sugeno((Rule((0, None), 0, consequent_negated=True),)), "cannot negate"),
     (lambda: FIS("m", (X,), OUT, (Rule((0,), 0),)), "need a Sugeno system"),
     (lambda: FIS("s", (X,), Variable("f", (0, 1), (L,)), (Rule((0,), 0),), kind="sugeno",
                  defuzzification="wtaver"), "constant or linear"),
     (lambda: FIS("s", (X,), OUT, (Rule((0,), 0),), kind="sugeno", defuzzification="wtaver"),
      "linear takes 2"),
     (lambda: _sugeno((Rule((0, None), 0),), d="centroid"), "wtaver, wtsum"),
     (lambda: FIS("k", (X,), OUT, (Rule((0,), 0),), kind="tsk"), "mamdani, sugeno"),
     (lambda: FIS("m", (X, Z), (OUT, OUT), (Rule((0, None), 0),), kind="sugeno",
                  defuzzification="wtaver"), "one entry per output")],
)
def test_bad_sugeno_and_multi_output_systems(make, match):
    with pytest.raises(InputError, match=match) as exc:
        make()
    assert "\n" not in str(exc.value)


def test_aggregate_is_for_mamdani_only():
    with pytest.raises(InputError, match="Mamdani"):
        _sugeno((Rule((0, None), 0),)).aggregate([0.2, 1.0])
