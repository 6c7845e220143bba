"""The distributions of a Monte Carlo sweep, each an inverse CDF of a uniform number.

Every distribution maps u in [0, 1) to a value (:meth:`Distribution.ppf`), so plain Monte
Carlo (u drawn per case) and a Latin hypercube (u stratified over the cases) sample the same
laws. Bounds truncate a law (the probability between them is rescaled, not piled up at the
bounds). A key's allowed range (:mod:`flexlift.sweep.keys`) is a bound too: where it cuts off
less than :data:`TAIL_MASS` of a law's probability it truncates silently (a normal drag
coefficient of 1.2 ± 0.1 and the range [0, 10]); where it cuts off more, the user must say so
with ``low`` / ``high``, so that no sample is ever outside what the schema allows.

Laws and their parameters (in the key's unit):

- ``normal``: ``mean``, ``std`` > 0; optional ``low``, ``high``
- ``lognormal``: ``median`` > 0, ``sigma`` > 0 (of the logarithm); optional ``low``, ``high``
- ``uniform``: ``low`` < ``high``
- ``loguniform``: 0 < ``low`` < ``high``
- ``triangular``: ``low`` <= ``mode`` <= ``high``, ``low`` < ``high``
- ``choice``: ``values`` (a list of any values the key takes); optional ``weights`` (as many,
  >= 0, not all 0; default equal)

A whole-number key (``hull.elements``) gets the nearest whole number of each sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexlift.errors import InputError, brief
from flexlift.sweep.keys import Key

#: largest probability a key's allowed range may cut off a law without the user's bounds
TAIL_MASS = 1e-6
#: least probability that must lie between a law's bounds
MIN_MASS = 1e-12

PARAMS = {
    "normal": ({"mean", "std"}, {"low", "high"}),
    "lognormal": ({"median", "sigma"}, {"low", "high"}),
    "uniform": ({"low", "high"}, set()),
    "loguniform": ({"low", "high"}, set()),
    "triangular": ({"low", "mode", "high"}, set()),
    "choice": ({"values"}, {"weights"}),
}


@dataclass(frozen=True)
class Distribution:
    """One key's law: ``kind``, its parameters (as given), and the support [low, high]
    after truncation (continuous laws) or the values and cumulative weights (choice)."""

    key: str
    kind: str
    params: tuple  # sorted (name, value) pairs as given, for the checksum and the report
    low: float = -math.inf
    high: float = math.inf
    values: tuple = ()
    cumulative: tuple = ()
    whole: bool = False

    def describe(self) -> str:
        """``normal(mean=1.2, std=0.1, low=0.8)``."""
        order = ["mean", "std", "median", "sigma", "low", "mode", "high", "values", "weights"]
        params = sorted(self.params, key=lambda kv: order.index(kv[0]))
        return f"{self.kind}(" + ", ".join(f"{k}={brief(v, 40)}" for k, v in params) + ")"

    def ppf(self, u: np.ndarray) -> list:
        """The values at the probabilities ``u`` (each in [0, 1)), as plain Python values."""
        u = np.asarray(u, dtype=float)
        if self.kind == "choice":
            idx = np.searchsorted(np.asarray(self.cumulative), u, side="right")
            return [self.values[min(int(i), len(self.values) - 1)] for i in idx]
        x = np.clip(_continuous(self.kind, dict(self.params), self.low, self.high, u),
                    self.low, self.high)
        if self.whole:
            return [int(v) for v in np.rint(x)]
        return [float(v) for v in x]


# --------------------------------------------------------------------------- the laws
def _cdf(kind: str, p: dict, x: float) -> float:
    from scipy import special  # here: only the normal laws need it (0.3 s of a sweep's start)

    if kind == "normal":
        return float(special.ndtr((x - p["mean"]) / p["std"]))
    if kind == "lognormal":
        return 0.0 if x <= 0 else float(special.ndtr(math.log(x / p["median"]) / p["sigma"]))
    raise AssertionError(kind)  # pragma: no cover - only the open laws have a CDF here


def _continuous(kind: str, p: dict, lo: float, hi: float, u: np.ndarray) -> np.ndarray:
    if kind == "uniform":
        return lo + u * (hi - lo)
    if kind == "loguniform":
        return lo * (hi / lo) ** u
    if kind == "triangular":
        c = (p["mode"] - lo) / (hi - lo)
        left = lo + np.sqrt(u * (hi - lo) * (p["mode"] - lo))
        right = hi - np.sqrt((1 - u) * (hi - lo) * (hi - p["mode"]))
        return np.where(u < c, left, right)
    from scipy import special

    f_lo, f_hi = _cdf(kind, p, lo), _cdf(kind, p, hi)
    q = special.ndtri(np.clip(f_lo + u * (f_hi - f_lo), 1e-300, 1 - 1e-16))
    if kind == "normal":
        return p["mean"] + p["std"] * q
    return p["median"] * np.exp(p["sigma"] * q)


# --------------------------------------------------------------------------- parsing
def parse_distribution(key: Key, spec, where: str) -> Distribution:
    """The :class:`Distribution` of ``spec`` (a mapping with ``dist`` and its parameters) for
    ``key``; an :class:`InputError` (one line, starting with ``where``) when it is invalid."""
    here = f"{where}.{key.name}"

    def fail(msg: str):
        raise InputError.from_line(f"{here}: {msg}")

    if not isinstance(spec, dict) or "dist" not in spec:
        fail(f"got {brief(spec)}; give a distribution such as {{dist: uniform, low: 1, "
             f"high: 2}} (dist: {', '.join(PARAMS)})")
    kind = spec["dist"]
    if kind not in PARAMS:
        fail(f"unknown dist {brief(kind, 40)}; use one of {', '.join(PARAMS)}")
    need, optional = PARAMS[kind]
    given = set(spec) - {"dist"}
    if missing := sorted(need - given):
        fail(f"{kind} needs {', '.join(_ordered(need))}; missing {', '.join(missing)}")
    if extra := sorted(given - need - optional):
        fail(f"{kind} takes {', '.join(_ordered(need) + sorted(optional))}; "
             f"unknown {', '.join(map(str, extra))}")
    params = tuple(sorted((k, spec[k]) for k in given))
    if kind == "choice":
        return _choice(key, dict(params), params, fail)
    if key.kind not in ("real", "whole"):
        fail(f"{key.name} is not a number ({key.kind}); use dist: choice with its values")
    p = {}
    for name, v in params:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            fail(f"{name} must be a finite number, got {brief(v, 40)}")
        p[name] = float(v)
    lo, hi = _support(kind, key, p, fail)
    return Distribution(key.name, kind, params, lo, hi, whole=key.kind == "whole")


def _ordered(need: set) -> list[str]:
    order = ["mean", "std", "median", "sigma", "low", "mode", "high", "values"]
    return sorted(need, key=order.index)


def _support(kind: str, key: Key, p: dict, fail) -> tuple[float, float]:
    allowed = f"{key.name} allows [{key.low:g}, {key.high:g}]"
    for name in ("low", "high", "mode"):
        if name in p and not key.low <= p[name] <= key.high:
            fail(f"{name} {p[name]:g} is outside what {allowed}")
    if kind in ("normal", "lognormal"):
        scale = p.get("std", p.get("sigma"))
        if scale <= 0:
            fail(f"{'std' if kind == 'normal' else 'sigma'} must be > 0, got {scale:g}")
        if kind == "lognormal" and p["median"] <= 0:
            fail(f"median must be > 0, got {p['median']:g}")
        lo, hi = p.get("low", key.low), p.get("high", key.high)
        if not lo < hi:
            fail(f"low {lo:g} must be below high {hi:g}")
        for side, bound, name in (("below", key.low, "low"), ("above", key.high, "high")):
            if name in p or not math.isfinite(bound):
                continue
            f = _cdf(kind, p, bound)
            cut = f if side == "below" else 1 - f
            if cut > TAIL_MASS:
                fail(f"{cut:.2%} of this {kind} law lies {side} {bound:g}, outside what "
                     f"{allowed}; bound it with {name}: (a value that must stay physical)")
        mass = _cdf(kind, p, hi) - _cdf(kind, p, lo)
        if mass < MIN_MASS:
            fail(f"almost no probability ({mass:.1e}) lies between low {lo:g} and high {hi:g}; "
                 "move the bounds or the centre")
        return lo, hi
    lo, hi = p["low"], p["high"]
    if not lo < hi:
        fail(f"low {lo:g} must be below high {hi:g}")
    if kind == "loguniform" and lo <= 0:
        fail(f"low must be > 0 for a loguniform law, got {lo:g}")
    if kind == "triangular" and not lo <= p["mode"] <= hi:
        fail(f"mode {p['mode']:g} must lie between low {lo:g} and high {hi:g}")
    return lo, hi


def _choice(key: Key, p: dict, params: tuple, fail) -> Distribution:
    values = p["values"]
    if not isinstance(values, list) or not values:
        fail(f"values must be a non-empty list, got {brief(values)}")
    weights = p.get("weights", [1.0] * len(values))
    if not isinstance(weights, list) or len(weights) != len(values):
        fail(f"weights must be a list of {len(values)} numbers (one per value), got {brief(weights)}")
    for w in weights:
        if isinstance(w, bool) or not isinstance(w, int | float) or not math.isfinite(w) or w < 0:
            fail(f"weights must be numbers >= 0, got {brief(w, 40)}")
    total = float(sum(weights))
    if total <= 0:
        fail("weights must not all be 0")
    if key.kind == "whole":
        values = [_whole(v, fail) for v in values]
    cum = np.cumsum(np.asarray(weights, dtype=float)) / total
    cum[-1] = 1.0
    return Distribution(key.name, "choice", params, values=tuple(values),
                        cumulative=tuple(float(c) for c in cum))


def _whole(v, fail):
    if (isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v)
            or v != int(v)):
        fail(f"values must be whole numbers, got {brief(v, 40)}")
    return int(v)
