"""The Mamdani engine: membership functions, every operator and defuzzifier by hand, shapes."""

import math

import numpy as np
import pytest
import skfuzzy

from flexlift.errors import InputError
from flexlift.fuzzy.system import (
    FIS,
    MF,
    Rule,
    Variable,
    gauss2mf,
    gaussmf,
    gbellmf,
    sigmf,
    trapmf,
    trimf,
)

X = np.linspace(-3.0, 3.0, 601)


# --------------------------------------------------------------------------- membership functions
def test_membership_functions_by_hand():
    assert gaussmf(0.5, 0.2, 0.5) == 1.0
    assert gaussmf(0.7, 0.2, 0.5) == pytest.approx(math.exp(-0.5), rel=1e-15)
    assert list(trimf([-1, 0, 0.5, 1, 2, 3], 0, 1, 2)) == [0, 0, 0.5, 1, 0, 0]
    assert list(trimf([0, 0.5, 1], 0, 0, 1)) == [1, 0.5, 0]  # left shoulder, MATLAB: mu(b) = 1
    assert list(trimf([0, 0.5, 1], 0, 1, 1)) == [0, 0.5, 1]  # right shoulder
    assert list(trapmf([0, 0.5, 1, 1.5, 2, 2.5, 3], 0, 1, 2, 3)) == [0, 0.5, 1, 1, 1, 0.5, 0]
    assert gbellmf([0.0, 2.0, -2.0], 2.0, 3.0, 0.0) == pytest.approx([1.0, 0.5, 0.5])
    assert sigmf(1.0, 4.0, 1.0) == 0.5
    assert sigmf(1.5, 4.0, 1.0) == pytest.approx(1 / (1 + math.exp(-2.0)))
    # two-sided gaussian: 1 on the plateau between the centres, a gaussian on each side
    assert list(gauss2mf([0.0, 0.5, 1.0], 0.3, 0.0, 0.5, 1.0)) == [1, 1, 1]
    assert gauss2mf(-0.3, 0.3, 0.0, 0.5, 1.0) == pytest.approx(math.exp(-0.5))
    assert gauss2mf(1.5, 0.3, 0.0, 0.5, 1.0) == pytest.approx(math.exp(-0.5))


def test_membership_functions_match_scikit_fuzzy():
    pairs = [
        (gaussmf(X, 0.7, 0.3), skfuzzy.gaussmf(X, 0.3, 0.7)),
        (gauss2mf(X, 0.4, -0.5, 0.8, 1.0), skfuzzy.gauss2mf(X, -0.5, 0.4, 1.0, 0.8)),
        (trimf(X, -1.0, 0.2, 2.0), skfuzzy.trimf(X, [-1.0, 0.2, 2.0])),
        (trapmf(X, -2.0, -1.0, 0.5, 2.5), skfuzzy.trapmf(X, [-2.0, -1.0, 0.5, 2.5])),
        (gbellmf(X, 1.5, 2.5, 0.3), skfuzzy.gbellmf(X, 1.5, 2.5, 0.3)),
        (sigmf(X, 3.0, 0.5), skfuzzy.sigmf(X, 0.5, 3.0)),
    ]
    for ours, theirs in pairs:
        np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(
    "fn, params",
    [(gaussmf, (0.0, 1.0)), (gbellmf, (1.0, 0.0, 0.0)), (trimf, (1.0, 0.0, 2.0)),
     (trapmf, (0.0, 2.0, 1.0, 3.0)), (gbellmf, (0.0, 2.0, 0.0)), (gauss2mf, (1.0, 0.0, 0.0, 1.0)),
     (trimf, (0.0, 1.0)), (sigmf, (float("nan"), 0.0))],
)
def test_bad_membership_parameters_raise_one_line(fn, params):
    with pytest.raises(InputError) as exc:
        fn(0.0, *params)
    assert "\n" not in str(exc.value) and fn.__name__ in str(exc.value)


def test_unknown_membership_kind():
    with pytest.raises(InputError, match="allowed: trimf"):
        MF("x", "cosmf", (1.0, 2.0))


# --------------------------------------------------------------------------- a hand-computed FIS
# Inputs x, z in [0, 1] with sets L = trimf(-1, 0, 1), H = trimf(0, 1, 2); output y in [0, 1]
# on 5 points (0, .25, .5, .75, 1) with lo = trimf(-1, 0, 1) -> [1, .75, .5, .25, 0] and
# hi = trimf(0, 1, 2) -> [0, .25, .5, .75, 1]. Rules: x L AND z L -> lo ; x H OR z H -> hi.
# At (x, z) = (0.25, 0.4): L(x) = .75, H(x) = .25, L(z) = .6, H(z) = .4.
def _hand_fis(**kw):
    L, H = MF("L", "trimf", (-1, 0, 1)), MF("H", "trimf", (0, 1, 2))
    x, z = Variable("x", (0, 1), (L, H)), Variable("z", (0, 1), (L, H))
    y = Variable("y", (0, 1), (MF("lo", "trimf", (-1, 0, 1)), MF("hi", "trimf", (0, 1, 2))))
    rules = (Rule((0, 0), 0), Rule((1, 1), 1, connective="or"))
    return FIS("hand", (x, z), y, rules, resolution=5, **kw)


P = [0.25, 0.4]
Y = np.array([0, 0.25, 0.5, 0.75, 1])


@pytest.mark.parametrize(
    "options, strengths, curve",
    [
        # min AND: .6; max OR: .4; min implication, max aggregation
        ({}, [0.6, 0.4], [0.6, 0.6, 0.5, 0.4, 0.4]),
        # prod AND: .75 * .6 = .45
        ({"and_method": "prod"}, [0.45, 0.4], [0.45, 0.45, 0.45, 0.4, 0.4]),
        # probor OR: .25 + .4 - .1 = .55
        ({"or_method": "probor"}, [0.6, 0.55], [0.6, 0.6, 0.5, 0.55, 0.55]),
        # prod implication: .6 lo = [.6 .45 .3 .15 0], .4 hi = [0 .1 .2 .3 .4]
        ({"implication": "prod"}, [0.6, 0.4], [0.6, 0.45, 0.3, 0.3, 0.4]),
        # sum aggregation of min cuts [.6 .6 .5 .25 0] + [0 .25 .4 .4 .4]
        ({"aggregation": "sum"}, [0.6, 0.4], [0.6, 0.85, 0.9, 0.65, 0.4]),
        # probor aggregation a + b - ab
        ({"aggregation": "probor"}, [0.6, 0.4], [0.6, 0.7, 0.7, 0.55, 0.4]),
        # sum aggregation of prod cuts (the matrix-product path)
        ({"aggregation": "sum", "implication": "prod"}, [0.6, 0.4], [0.6, 0.55, 0.5, 0.45, 0.4]),
    ],
)
def test_every_operator_by_hand(options, strengths, curve):
    fis = _hand_fis(**options)
    np.testing.assert_allclose(fis.firing_strengths(P), strengths, rtol=1e-14)
    np.testing.assert_allclose(fis.aggregate(P), curve, rtol=1e-14)
    # MATLAB's discrete centroid of that curve
    assert fis(P) == pytest.approx(np.dot(Y, curve) / np.sum(curve), rel=1e-14)


def test_every_defuzzifier_by_hand():
    # curve [.6 .6 .5 .4 .4]: sum 2.5, sum y mu = .15 + .25 + .3 + .4 = 1.1
    f = _hand_fis()
    assert f(P) == pytest.approx(1.1 / 2.5, rel=1e-14)
    # bisector: running sums .6 1.2 1.7 ...; the first >= 1.25 is at y = .5
    assert f.with_options(defuzzification="bisector")(P) == 0.5
    # maximum .6 at y = 0 and .25
    assert f.with_options(defuzzification="mom")(P) == 0.125
    assert f.with_options(defuzzification="som")(P) == 0.0
    assert f.with_options(defuzzification="lom")(P) == 0.25
    # trapezoids: [0,.25] .6-.6 area .15 at .125; [.25,.5] .6-.5 area .1375 at .25+.25*1.6/3.3;
    # [.5,.75] .5-.4 area .1125 at .5+.25*1.3/2.7; [.75,1] .4-.4 area .1 at .875
    areas = [0.15, 0.1375, 0.1125, 0.1]
    cents = [0.125, 0.25 + 0.25 * 1.6 / 3.3, 0.5 + 0.25 * 1.3 / 2.7, 0.875]
    expected = np.dot(areas, cents) / sum(areas)
    assert f.with_options(defuzzification="centroid_trapz")(P) == pytest.approx(expected, rel=1e-14)
    assert expected == pytest.approx(skfuzzy.defuzz(Y, np.array([.6, .6, .5, .4, .4]), "centroid"))


def test_rule_weight_negation_and_dont_care():
    base = _hand_fis()
    half = FIS("w", base.inputs, base.output, (Rule((0, 0), 0, weight=0.5), base.rules[1]),
               resolution=5)
    np.testing.assert_allclose(half.firing_strengths(P), [0.3, 0.4])
    # NOT x is L (1 - .75 = .25) AND z is L (.6) -> .25; z don't care in an OR rule -> H(x) = .25
    neg = FIS("n", base.inputs, base.output,
              (Rule((0, 0), 0, negated=(True, False)), Rule((1, None), 1, connective="or")),
              resolution=5)
    np.testing.assert_allclose(neg.firing_strengths(P), [0.25, 0.25])
    # don't care in an AND rule counts as 1: x is H AND (any z) -> .25
    anyz = FIS("a", base.inputs, base.output, (Rule((1, None), 1),), resolution=5)
    np.testing.assert_allclose(anyz.firing_strengths(P), [0.25])
    # negated consequent: NOT lo = hi's shape here, so u equals the hi-only system's
    notlo = FIS("c", base.inputs, base.output, (Rule((1, None), 0, consequent_negated=True),),
                resolution=5)
    assert notlo(P) == pytest.approx(anyz(P), rel=1e-14)


def test_no_rule_fired_gives_mid_range_for_every_method():
    narrow = Variable("x", (0, 10), (MF("a", "trimf", (0, 1, 2)),))
    out = Variable("y", (-3, 5), (MF("b", "trimf", (-3, 0, 5)),))
    fis = FIS("dead", (narrow,), out, (Rule((0,), 0),))
    for method in ("centroid", "centroid_trapz", "bisector", "mom", "som", "lom"):
        assert fis.with_options(defuzzification=method)(9.0) == 1.0  # (-3 + 5) / 2
    assert fis(1.5) != 1.0


def test_shapes_saturation_and_bad_input():
    f = _hand_fis()
    pts = np.random.default_rng(3).uniform(-0.5, 1.5, (50, 2))
    batch = f(pts)
    assert batch.shape == (50,)
    assert np.array_equal(batch, [f(p) for p in pts])  # batch == one-by-one
    assert isinstance(f(P), float)
    assert f([7.0, -3.0]) == f([1.0, 0.0])  # saturated to the ranges
    assert f.firing_strengths(pts).shape == (50, 2)
    with pytest.raises(InputError, match="NaN"):
        f([np.nan, 0.2])
    with pytest.raises(InputError, match="shape"):
        f([0.1, 0.2, 0.3])
    one = FIS("one", (f.inputs[0],), f.output, (Rule((0,), 0), Rule((1,), 1)), resolution=5)
    assert isinstance(one(0.3), float)
    assert one(np.array([0.3, 0.6])).shape == (2,)
    assert np.array_equal(one(np.array([[0.3], [0.6]])), one(np.array([0.3, 0.6])))


def test_large_batch_is_chunked_and_equal():
    f = _hand_fis(aggregation="probor")
    pts = np.random.default_rng(4).uniform(0, 1, (f._compiled.chunk * 2 + 7, 2))
    u = f(pts)
    np.testing.assert_array_equal(u[-7:], f(pts[-7:]))


@pytest.mark.parametrize(
    "change, match",
    [({"and_method": "max"}, "and_method"), ({"defuzzification": "wtaver"}, "defuzzification"),
     ({"resolution": 2}, "resolution"), ({"rules": (Rule((0, 2), 0),)}, "has 2 sets"),
     ({"rules": (Rule((0, 0), 5),)}, "output"), ({"rules": (Rule((0, 0), 0, weight=2),)}, "weight"),
     ({"rules": (Rule((0,), 0),)}, "one entry per input")],
)
def test_bad_systems_raise_one_line(change, match):
    base = _hand_fis()
    kw = {"name": "bad", "inputs": base.inputs, "outputs": base.output, "rules": base.rules}
    with pytest.raises(InputError, match=match) as exc:
        FIS(**{**kw, **change})
    assert "\n" not in str(exc.value)


def test_variable_range_validated():
    with pytest.raises(InputError, match="range"):
        Variable("x", (1.0, 1.0), (MF("a", "gaussmf", (1, 0)),))
