"""Every membership function of the Fuzzy Logic Toolbox: against scikit-fuzzy, against the
values the Octave Fuzzy Logic Toolkit's own tests publish, against the plain reference."""

import math

import numpy as np
import pytest
import skfuzzy
from fis_reference import membership

from flexlift.errors import InputError
from flexlift.fuzzy.system import (
    MF,
    MF_KINDS,
    dsigmf,
    gauss2mf,
    gaussmf,
    gbellmf,
    linsmf,
    linzmf,
    pimf,
    psigmf,
    sigmf,
    smf,
    trapmf,
    trimf,
    zmf,
)

X = np.linspace(-3.0, 3.0, 601)


@pytest.mark.parametrize(
    "ours, theirs",
    [(lambda: smf(X, -1.2, 1.7), lambda: skfuzzy.smf(X, -1.2, 1.7)),
     (lambda: zmf(X, -1.2, 1.7), lambda: skfuzzy.zmf(X, -1.2, 1.7)),
     (lambda: pimf(X, -2.0, -0.5, 0.4, 2.2), lambda: skfuzzy.pimf(X, -2.0, -0.5, 0.4, 2.2)),
     (lambda: psigmf(X, 4.0, -1.0, -3.0, 1.5), lambda: skfuzzy.psigmf(X, -1.0, 4.0, 1.5, -3.0)),
     # scikit-fuzzy's dsigmf is the signed difference; equal where sig1 >= sig2
     (lambda: dsigmf(X, 5.0, -1.0, 5.0, 1.0), lambda: skfuzzy.dsigmf(X, -1.0, 5.0, 1.0, 5.0))],
)
def test_spline_and_sigmoid_sets_match_scikit_fuzzy(ours, theirs):
    np.testing.assert_allclose(ours(), theirs(), rtol=1e-12, atol=1e-15)


# Values published by the Octave Fuzzy Logic Toolkit's tests (inst/*.m, %!test blocks, 4 digits)
OCTAVE = [
    (smf, np.arange(0, 101, 10), (25, 75), [0, 0, 0, 0.02, 0.18, 0.5, 0.82, 0.98, 1, 1, 1]),
    (zmf, np.arange(0, 101, 10), (25, 75), [1, 1, 1, 0.98, 0.82, 0.5, 0.18, 0.02, 0, 0, 0]),
    (pimf, np.arange(0, 251, 25), (50, 75, 105, 175),
     [0, 0, 0, 1, 1, 0.8367, 0.2551, 0, 0, 0, 0]),
    (dsigmf, np.arange(0, 11), (5, 2, 3, 6),
     [4.5383e-05, 6.6925e-03, 0.5, 0.9932, 0.9975, 0.9526, 0.5, 0.047426, 2.4726e-03,
      1.2339e-04, 6.1442e-06]),
    (psigmf, np.arange(0, 101, 10), (0.3, 20, -0.2, 60),
     [2.4726e-03, 0.047424, 0.4998, 0.9502, 0.9796, 0.8807, 0.5, 0.1192, 0.017986, 2.4726e-03,
      3.3535e-04]),
    (gbellmf, np.arange(0, 251, 25), (40, 2, 100),
     [0.024961, 0.074852, 0.2906, 0.8676, 1, 0.8676, 0.2906, 0.074852, 0.024961, 0.010377,
      5.0313e-03]),
    (gauss2mf, np.arange(-10, 11, 2), (3, 0, 1.5, 2),
     [3.8659e-03, 0.028566, 0.1353, 0.4111, 0.8007, 1, 1, 0.4111, 0.028566, 3.3546e-04,
      6.6584e-07]),
    (sigmf, np.arange(0, 11), (5, 2), [4.5398e-05, 6.6929e-03, 0.5, 0.9933, 1, 1, 1, 1, 1, 1, 1]),
    (gaussmf, np.arange(-5, 6), (2, 0),
     [0.043937, 0.1353, 0.3247, 0.6065, 0.8825, 1, 0.8825, 0.6065, 0.3247, 0.1353, 0.043937]),
    (trimf, np.arange(0, 11), (2, 4, 6), [0, 0, 0, 0.5, 1, 0.5, 0, 0, 0, 0, 0]),
    (trapmf, np.arange(0, 11), (-1, 0, 2, 4), [1, 1, 1, 0.5, 0, 0, 0, 0, 0, 0, 0]),
    (linsmf, np.arange(0, 5.1, 0.5), (2, 4), [0, 0, 0, 0, 0, 0.25, 0.5, 0.75, 1, 1, 1]),
    (linsmf, np.arange(0, 5.1, 0.5), (3, 3), [0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1]),
    (linzmf, np.arange(0, 5.1, 0.5), (2, 4), [1, 1, 1, 1, 1, 0.75, 0.5, 0.25, 0, 0, 0]),
    (linzmf, np.arange(0, 5.1, 0.5), (3, 3), [1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0]),
]


@pytest.mark.parametrize("fn, x, params, expected", OCTAVE, ids=[o[0].__name__ for o in OCTAVE])
def test_published_values_of_the_octave_toolkit(fn, x, params, expected):
    np.testing.assert_allclose(fn(x, *params), expected, rtol=1e-3, atol=1e-4)


def test_splines_by_hand_and_their_degenerate_step():
    # smf [0 4]: 2 (x/4)^2 up to 2, 1 - 2 ((4 - x)/4)^2 after
    assert list(smf([-1, 1, 2, 3, 4, 5], 0, 4)) == [0, 0.125, 0.5, 0.875, 1, 1]
    assert list(zmf([-1, 1, 2, 3, 4, 5], 0, 4)) == [1, 0.875, 0.5, 0.125, 0, 0]
    # a >= b: a step at (a + b) / 2, as MATLAB
    assert list(smf([1.9, 2.0, 2.1], 3, 1)) == [0, 1, 1]
    assert list(zmf([1.9, 2.0, 2.1], 3, 1)) == [1, 1, 0]
    assert list(pimf([0, 1, 2, 3, 4, 5, 6], 0, 2, 4, 6)) == [0, 0.5, 1, 1, 1, 0.5, 0]
    # dsigmf is |sig1 - sig2| (MATLAB's implementation), psigmf the product
    s = 1 / (1 + math.exp(-1.0))
    assert dsigmf(0.0, 1, -1, 1, 1) == pytest.approx(s - (1 - s), rel=1e-15)
    assert dsigmf(0.0, 1, 1, 1, -1) == pytest.approx(s - (1 - s), rel=1e-15)
    assert psigmf(0.0, 1, -1, -1, 1) == pytest.approx(s * s, rel=1e-15)


@pytest.mark.parametrize("kind", sorted(MF_KINDS))
def test_every_kind_matches_the_plain_reference(kind):
    rng = np.random.default_rng(sorted(MF_KINDS).index(kind))
    x = np.concatenate([np.linspace(-2, 2, 401), rng.uniform(-2, 2, 200)])
    n = len(MF_KINDS[kind][1])
    for trial in range(40):
        p = np.sort(rng.uniform(-1.5, 1.5, n)) if kind in ("trimf", "trapmf", "linsmf", "linzmf",
                                                          "pimf") else rng.uniform(-1.5, 1.5, n)
        if trial % 5 == 0 and n >= 2:  # degenerate: equal breakpoints, or reversed for splines
            p[1] = p[0]
        if kind in ("gaussmf", "gauss2mf"):
            p[0] = abs(p[0]) + 0.05
            p[n - 2] = abs(p[n - 2]) + 0.05 if n == 4 else p[n - 2]
        if kind == "gbellmf":
            p[0], p[1] = abs(p[0]) + 0.05, abs(p[1]) + 0.2
        if kind in ("sigmf", "dsigmf", "psigmf"):
            p[0::2] *= 6
        try:
            m = MF("m", kind, tuple(p))
        except InputError:
            continue
        ref = [membership(kind, m.params, float(v)) for v in x]
        np.testing.assert_allclose(m(x), ref, rtol=1e-12, atol=1e-14, err_msg=str(m.params))


@pytest.mark.parametrize(
    "fn, params, match",
    [(linsmf, (2.0, 1.0), "a <= b"), (linzmf, (2.0, 1.0), "a <= b"),
     (pimf, (0.0, 1.0, 2.0), r"pimf takes 4: \[a b c d\]"), (smf, (1.0,), "smf takes 2"),
     (dsigmf, (1.0, 2.0, float("inf"), 0.0), "finite"), (gauss2mf, (1.0, 0.0, 0.0, 1.0), "sigma2")],
)
def test_bad_parameters_of_the_new_kinds(fn, params, match):
    with pytest.raises(InputError, match=match) as exc:
        fn(0.0, *params)
    assert "\n" not in str(exc.value)


def test_negative_sigma_is_read_as_matlab_does():
    np.testing.assert_array_equal(gaussmf(X, -0.4, 0.2), gaussmf(X, 0.4, 0.2))


def test_sugeno_output_functions():
    lin = MF("l", "linear", (2.0, -1.0, 0.5))
    assert lin([3.0, 4.0]) == 2.5
    np.testing.assert_array_equal(lin(np.array([[3.0, 4.0], [0.0, 0.0]])), [2.5, 0.5])
    const = MF("c", "constant", (7.0,))
    np.testing.assert_array_equal(const(np.zeros((4, 2))), [7.0] * 4)
    with pytest.raises(InputError, match="constant takes 1"):
        MF("c", "constant", (1.0, 2.0))
