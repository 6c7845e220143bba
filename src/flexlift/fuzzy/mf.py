"""Membership functions of MATLAB's Fuzzy Logic Toolbox, in its parameter order, vectorised.

Input (and Mamdani output) sets, ``mu = kernel(x, *params)``, x in the variable's unit:

- ``trimf`` [a b c], ``trapmf`` [a b c d]: piecewise linear; a == b or c == d is a vertical
  side (membership 1 at the shoulder, as MATLAB's trimf/trapmf).
- ``gaussmf`` [sigma c]: exp(-(x - c)^2 / (2 sigma^2)); ``gauss2mf`` [sigma1 c1 sigma2 c2]: the
  left Gaussian below c1, the right one above c2, 1 between (their product where they overlap).
- ``gbellmf`` [a b c]: 1 / (1 + |(x - c)/a|^(2b)).
- ``sigmf`` [a c]: 1 / (1 + exp(-a (x - c))); ``dsigmf`` [a1 c1 a2 c2]: |sig1 - sig2| (MATLAB
  takes the absolute difference; for the usual parameters sig1 >= sig2 it is the difference);
  ``psigmf`` [a1 c1 a2 c2]: sig1 * sig2.
- ``smf`` [a b]: the quadratic spline 0 -> 1 from a to b (2((x-a)/(b-a))^2 up to the midpoint,
  1 - 2((b-x)/(b-a))^2 after); ``zmf`` [a b] its mirror 1 -> 0; with a >= b both are a step at
  (a + b)/2, as MATLAB. ``pimf`` [a b c d] = smf(x, a, b) * zmf(x, c, d).
- ``linsmf`` [a b]: linear 0 -> 1 from a to b; ``linzmf`` [a b]: linear 1 -> 0 (a <= b; a == b
  is a step at a).

Sugeno output functions (of the input vector, not of a universe): ``constant`` [c] and
``linear`` [a1 .. an c] meaning a1 x1 + ... + an xn + c.
"""

from __future__ import annotations

import numpy as np

from flexlift.errors import InputError


# --------------------------------------------------------------------------- kernels
# x broadcastable against the parameter arrays (one entry per set); no validation here.
def _k_gauss(x, s, c):
    return np.exp(-((x - c) ** 2) / (2.0 * s * s))


def _k_gauss_fast(x, c, k):  # the engine's form of gaussmf: exp(k (x - c)^2), k = -1/(2 s^2)
    d = x - c
    return np.exp(d * d * k)


def _k_gauss2(x, s1, c1, s2, c2):
    left = np.where(x <= c1, _k_gauss(x, s1, c1), 1.0)
    right = np.where(x >= c2, _k_gauss(x, s2, c2), 1.0)
    return left * right


def _ramp_up(x, a, b):  # 0 below a, linear to 1 at b, 1 above (a step at b when a == b)
    d = np.where(b > a, b - a, 1.0)
    return np.where(b > a, (x - a) / d, (x >= b) * 1.0)


def _ramp_down(x, c, d):  # 1 below c, linear to 0 at d, 0 above (a step at c when c == d)
    w = np.where(d > c, d - c, 1.0)
    return np.where(d > c, (d - x) / w, (x <= c) * 1.0)


def _k_tri(x, a, b, c):
    return np.clip(np.minimum(_ramp_up(x, a, b), _ramp_down(x, b, c)), 0.0, 1.0)


def _k_trap(x, a, b, c, d):
    return np.clip(np.minimum(_ramp_up(x, a, b), _ramp_down(x, c, d)), 0.0, 1.0)


def _k_gbell(x, a, b, c):
    return 1.0 / (1.0 + np.abs((x - c) / a) ** (2.0 * b))


def _k_sig(x, a, c):
    return 1.0 / (1.0 + np.exp(-a * (x - c)))


def _k_dsig(x, a1, c1, a2, c2):
    return np.abs(_k_sig(x, a1, c1) - _k_sig(x, a2, c2))


def _k_psig(x, a1, c1, a2, c2):
    return _k_sig(x, a1, c1) * _k_sig(x, a2, c2)


def _k_s(x, a, b):
    w = np.where(b > a, b - a, 1.0)
    m = 0.5 * (a + b)
    rise = np.where(x <= m, 2.0 * ((x - a) / w) ** 2, 1.0 - 2.0 * ((b - x) / w) ** 2)
    spline = np.where(x <= a, 0.0, np.where(x <= b, rise, 1.0))
    return np.where(b > a, spline, (x >= m) * 1.0)


def _k_z(x, a, b):
    w = np.where(b > a, b - a, 1.0)
    m = 0.5 * (a + b)
    fall = np.where(x <= m, 1.0 - 2.0 * ((x - a) / w) ** 2, 2.0 * ((b - x) / w) ** 2)
    spline = np.where(x <= a, 1.0, np.where(x <= b, fall, 0.0))
    return np.where(b > a, spline, (x <= m) * 1.0)


def _k_pi(x, a, b, c, d):
    return _k_s(x, a, b) * _k_z(x, c, d)


def _k_lins(x, a, b):
    d = np.where(b > a, b - a, 1.0)
    return np.where(b > a, np.clip((x - a) / d, 0.0, 1.0), (x >= a) * 1.0)


def _k_linz(x, a, b):
    d = np.where(b > a, b - a, 1.0)
    return np.where(b > a, np.clip((b - x) / d, 0.0, 1.0), (x < a) * 1.0)


# --------------------------------------------------------------------------- validators
def _ordered(*names):
    def check(p):
        return all(u <= v for u, v in zip(p, p[1:])) or f"needs {' <= '.join(names)}"
    return check


def _v_gauss(p):
    return p[0] != 0 or "needs sigma != 0"


def _v_gauss2(p):
    return (p[0] != 0 and p[2] != 0) or "needs sigma1 != 0 and sigma2 != 0"


def _v_gbell(p):
    return (p[0] != 0 and p[1] > 0) or "needs a != 0 and b > 0"


def _any(p):
    return True


#: kind -> (kernel, parameter names, validator returning True or the rule broken)
MF_KINDS = {
    "trimf": (_k_tri, ("a", "b", "c"), _ordered("a", "b", "c")),
    "trapmf": (_k_trap, ("a", "b", "c", "d"), _ordered("a", "b", "c", "d")),
    "gaussmf": (_k_gauss, ("sigma", "c"), _v_gauss),
    "gauss2mf": (_k_gauss2, ("sigma1", "c1", "sigma2", "c2"), _v_gauss2),
    "gbellmf": (_k_gbell, ("a", "b", "c"), _v_gbell),
    "sigmf": (_k_sig, ("a", "c"), _any),
    "dsigmf": (_k_dsig, ("a1", "c1", "a2", "c2"), _any),
    "psigmf": (_k_psig, ("a1", "c1", "a2", "c2"), _any),
    "smf": (_k_s, ("a", "b"), _any),
    "zmf": (_k_z, ("a", "b"), _any),
    "pimf": (_k_pi, ("a", "b", "c", "d"), _any),
    "linsmf": (_k_lins, ("a", "b"), _ordered("a", "b")),
    "linzmf": (_k_linz, ("a", "b"), _ordered("a", "b")),
}
#: Sugeno output functions: of the input vector (``linear`` takes one coefficient per input + c)
OUTPUT_FUNCTIONS = ("constant", "linear")
ALL_KINDS = (*MF_KINDS, *OUTPUT_FUNCTIONS)


def check_mf(kind: str, params, where: str = "membership function") -> tuple[float, ...]:
    """Validate a membership function's kind and parameters; returns the parameters as floats.

    ``linear``'s parameter count depends on the system (one per input + 1): checked by the FIS.
    """
    if kind not in ALL_KINDS:
        raise InputError(f"{where} type", kind, f"allowed: {', '.join(ALL_KINDS)}")
    names = MF_KINDS[kind][1] if kind in MF_KINDS else ("c",) if kind == "constant" else ()
    try:
        p = tuple(float(v) for v in params)
    except (TypeError, ValueError):
        raise InputError(f"{where} parameters", params, f"{kind} takes numbers") from None
    if kind == "linear":
        if not p:
            raise InputError(f"{where} parameters", [], "linear takes [a1 .. an c]")
    elif len(p) != len(names):
        raise InputError(f"{where} parameters", list(p),
                         f"{kind} takes {len(names)}: [{' '.join(names)}]")
    if not all(np.isfinite(p)):
        raise InputError(f"{where} parameters", list(p), "must be finite")
    ok = MF_KINDS[kind][2](p) if kind in MF_KINDS else True
    if ok is not True:
        raise InputError(f"{where} parameters", list(p), f"{kind} {ok}")
    return p


def _public(kind):
    kernel, names, _ = MF_KINDS[kind]

    def mf(x, *params):
        p = check_mf(kind, params, kind)
        return kernel(np.asarray(x, dtype=float), *p)

    mf.__name__ = kind
    mf.__doc__ = (f"MATLAB's ``{kind}``: membership of ``x`` (array, any unit) with parameters "
                  f"{', '.join(names)} (same unit as x); vectorised, parameters validated.")
    return mf


trimf = _public("trimf")
trapmf = _public("trapmf")
gaussmf = _public("gaussmf")
gauss2mf = _public("gauss2mf")
gbellmf = _public("gbellmf")
sigmf = _public("sigmf")
dsigmf = _public("dsigmf")
psigmf = _public("psigmf")
smf = _public("smf")
zmf = _public("zmf")
pimf = _public("pimf")
linsmf = _public("linsmf")
linzmf = _public("linzmf")
