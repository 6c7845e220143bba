"""A small, pure, vectorised Mamdani fuzzy inference engine with MATLAB's operator set.

A :class:`FIS` is immutable data (input/output :class:`Variable` s with their membership
functions, :class:`Rule` s as index tuples, the operator names); evaluating it is one pure call,
``u = fis(x)``, for one point or an array of points, vectorised with NumPy over points and
rules (no Python loop over points, no set-input/compute/read-output state).

Semantics follow MATLAB's Fuzzy Logic Toolbox (``evalfis``, Mamdani type):

- rule firing strength = AND (min | prod) or OR (max | probor) of the antecedent memberships,
  times the rule weight; an antecedent index ``None`` ("don't care") is skipped, a negated
  antecedent uses 1 - mu;
- implication (min | prod) of each rule's strength with its output set sampled on
  ``resolution`` evenly spaced points of the output range (default 101, as MATLAB);
- aggregation (max | sum | probor) over the rules;
- defuzzification: ``centroid`` is MATLAB's discrete one, sum(y mu) / sum(mu) over the grid;
  ``centroid_trapz`` is the piecewise-linear (trapezoidal) centroid of the sampled curve, equal
  to ``skfuzzy.defuzz(y, mu, "centroid")``; ``bisector`` is MATLAB's discrete one (the first
  grid point where the running sum reaches half the total); ``mom``, ``som``, ``lom`` the
  mean, smallest and largest grid value where the curve is at its maximum (as the current
  MATLAB documentation and scikit-fuzzy define them; note that some old MATLAB releases took
  the smallest/largest *absolute* value).
- If no rule fires (the aggregated curve is zero everywhere), the output is the middle of the
  output range, as MATLAB does (it also prints a warning; we log one at DEBUG level).
- Inputs outside an input's range are saturated (clipped) to the range before evaluation
  (MATLAB warns and extrapolates the membership functions instead); NaN raises InputError.

Membership functions take MATLAB's parameter order: ``gaussmf(x, sigma, c)``,
``gauss2mf(x, sigma1, c1, sigma2, c2)``, ``trimf(x, a, b, c)``, ``trapmf(x, a, b, c, d)``,
``gbellmf(x, a, b, c)``, ``sigmf(x, a, c)``. Units: those of the variable they describe.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from flexlift.errors import InputError

log = logging.getLogger(__name__)

AND_METHODS = ("min", "prod")
OR_METHODS = ("max", "probor")
IMPLICATIONS = ("min", "prod")
AGGREGATIONS = ("max", "sum", "probor")
DEFUZZIFICATIONS = ("centroid", "centroid_trapz", "bisector", "mom", "som", "lom")
ERROR_SAFETY = 1.5  # interpolated surface: stated bound / measured maximum error
_CHUNK = 1 << 21  # elements per (points x sets x grid) block: bounds the memory of a batch


# --------------------------------------------------------------------------- membership functions
# Kernels take x broadcastable against the parameter arrays; no validation (done once).
def _k_gauss(x, s, c):
    return np.exp(-((x - c) ** 2) / (2.0 * s * s))


def _k_gauss_fast(x, c, k):
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


def _v_gauss(p):
    return p[0] > 0 or "sigma must be > 0"


def _v_gauss2(p):
    return (p[0] > 0 and p[2] > 0) or "sigma1 and sigma2 must be > 0"


def _v_tri(p):
    return p[0] <= p[1] <= p[2] or "needs a <= b <= c"


def _v_trap(p):
    return p[0] <= p[1] <= p[2] <= p[3] or "needs a <= b <= c <= d"


def _v_gbell(p):
    return (p[0] != 0 and p[1] > 0) or "needs a != 0 and b > 0"


#: kind -> (kernel, parameter names, validator returning True or the rule broken)
MF_KINDS = {
    "gaussmf": (_k_gauss, ("sigma", "c"), _v_gauss),
    "gauss2mf": (_k_gauss2, ("sigma1", "c1", "sigma2", "c2"), _v_gauss2),
    "trimf": (_k_tri, ("a", "b", "c"), _v_tri),
    "trapmf": (_k_trap, ("a", "b", "c", "d"), _v_trap),
    "gbellmf": (_k_gbell, ("a", "b", "c"), _v_gbell),
    "sigmf": (_k_sig, ("a", "c"), lambda p: True),
}


def check_mf(kind: str, params, where: str = "membership function") -> tuple[float, ...]:
    """Validate a membership function's kind and parameters; returns the parameters as floats."""
    if kind not in MF_KINDS:
        raise InputError(f"{where} type", kind, f"allowed: {', '.join(MF_KINDS)}")
    names = MF_KINDS[kind][1]
    try:
        p = tuple(float(v) for v in params)
    except (TypeError, ValueError):
        raise InputError(f"{where} parameters", params, f"{kind} takes numbers {list(names)}") from None
    if len(p) != len(names):
        raise InputError(f"{where} parameters", list(p), f"{kind} takes {len(names)}: {list(names)}")
    if not all(np.isfinite(p)):
        raise InputError(f"{where} parameters", list(p), "must be finite")
    ok = MF_KINDS[kind][2](p)
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


gaussmf = _public("gaussmf")
gauss2mf = _public("gauss2mf")
trimf = _public("trimf")
trapmf = _public("trapmf")
gbellmf = _public("gbellmf")
sigmf = _public("sigmf")


# --------------------------------------------------------------------------- data
@dataclass(frozen=True)
class MF:
    """A named membership function: ``kind`` (a key of MF_KINDS) and MATLAB-order ``params``."""

    name: str
    kind: str
    params: tuple[float, ...]

    def __post_init__(self):
        object.__setattr__(self, "params", check_mf(self.kind, self.params, f"set {self.name!r}"))

    def __call__(self, x):
        return MF_KINDS[self.kind][0](np.asarray(x, dtype=float), *self.params)


@dataclass(frozen=True)
class Variable:
    """A linguistic variable: name, range (lo, hi) [its unit] and its membership functions."""

    name: str
    range: tuple[float, float]
    mfs: tuple[MF, ...]

    def __post_init__(self):
        lo, hi = (float(v) for v in self.range)
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise InputError(f"variable {self.name!r} range", [lo, hi], "needs finite lo < hi")
        if not self.mfs:
            raise InputError(f"variable {self.name!r} sets", 0, "needs at least one set")
        object.__setattr__(self, "range", (lo, hi))
        object.__setattr__(self, "mfs", tuple(self.mfs))

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.mfs)


@dataclass(frozen=True)
class Rule:
    """IF input_i is set antecedent[i] (AND|OR ...) THEN output is set consequent.

    Indices are 0-based into each variable's ``mfs``; ``None`` means "don't care";
    ``negated[i]`` (default all False) uses NOT (1 - mu); ``weight`` in [0, 1].
    """

    antecedent: tuple[int | None, ...]
    consequent: int
    weight: float = 1.0
    connective: str = "and"
    negated: tuple[bool, ...] = ()
    consequent_negated: bool = False

    def __post_init__(self):
        object.__setattr__(self, "antecedent", tuple(self.antecedent))
        object.__setattr__(self, "negated", tuple(bool(v) for v in self.negated)
                           or (False,) * len(self.antecedent))


@dataclass(frozen=True)
class FIS:
    """A Mamdani fuzzy inference system (one output). Call it: ``u = fis(x)``.

    ``x``: shape (n_inputs,) -> float; (n, n_inputs) -> array (n,). A one-input system also
    takes a scalar or shape (n,). Inputs beyond a variable's range are saturated to it.
    """

    name: str
    inputs: tuple[Variable, ...]
    output: Variable
    rules: tuple[Rule, ...]
    and_method: str = "min"
    or_method: str = "max"
    implication: str = "min"
    aggregation: str = "max"
    defuzzification: str = "centroid"
    resolution: int = 101

    def __post_init__(self):
        object.__setattr__(self, "inputs", tuple(self.inputs))
        object.__setattr__(self, "rules", tuple(self.rules))
        for fld, allowed in (("and_method", AND_METHODS), ("or_method", OR_METHODS),
                             ("implication", IMPLICATIONS), ("aggregation", AGGREGATIONS),
                             ("defuzzification", DEFUZZIFICATIONS)):
            if getattr(self, fld) not in allowed:
                raise InputError(fld, getattr(self, fld), f"allowed: {', '.join(allowed)}")
        if isinstance(self.resolution, bool) or int(self.resolution) != self.resolution \
                or self.resolution < 3:
            raise InputError("resolution", self.resolution, "a whole number of points >= 3")
        object.__setattr__(self, "resolution", int(self.resolution))
        if not self.inputs:
            raise InputError("inputs", 0, "needs at least one input variable")
        if not self.rules:
            raise InputError("rules", 0, "needs at least one rule")
        for k, r in enumerate(self.rules, 1):
            _check_rule(k, r, self.inputs, self.output)

    # ---------------------------------------------------------------- evaluation
    @property
    def n_inputs(self) -> int:
        return len(self.inputs)

    @cached_property
    def output_grid(self) -> np.ndarray:
        """The output universe's sample points (``resolution`` of them) [output unit]."""
        lo, hi = self.output.range
        return np.linspace(lo, hi, self.resolution)

    def with_options(self, **changes) -> FIS:
        """A copy with operators changed, e.g. ``fis.with_options(defuzzification="mom")``."""
        return replace(self, **changes)

    def points(self, x) -> tuple[np.ndarray, bool]:
        """Inputs as a saturated (n, n_inputs) array, and whether a single point was given."""
        a = np.asarray(x, dtype=float)
        m = self.n_inputs
        if a.ndim == 2 and a.shape[1] == m:
            single = False
        elif a.ndim == 1 and a.shape[0] == m and m > 1:
            a, single = a[None, :], True
        elif m == 1 and a.ndim <= 1:
            single = a.ndim == 0
            a = a.reshape(-1, 1)
        else:
            raise InputError("inputs shape", a.shape, f"({m},) or (n, {m}) for this system")
        total = a.sum()  # one cheap reduction; NaN (or inf - inf) only then look closer
        if total != total and np.isnan(a).any():
            raise InputError("inputs", "NaN", "finite numbers (values beyond a range are saturated)")
        c = self._compiled
        return np.minimum(np.maximum(a, c.lo), c.hi), single

    def firing_strengths(self, x) -> np.ndarray:
        """Rule firing strengths times weights, shape (n, n_rules) (or (n_rules,) for one point)."""
        a, single = self.points(x)
        c = self._compiled
        w = _fire(c, a, self.and_method, self.or_method)[:, c.inverse]
        return w[0] if single else w

    def aggregate(self, x) -> np.ndarray:
        """The aggregated output membership on ``output_grid``: (n, resolution) (or (resolution,))."""
        a, single = self.points(x)
        c = self._compiled
        agg = np.concatenate([self._aggregate(c, a[i:i + c.chunk])
                              for i in range(0, max(len(a), 1), c.chunk)])
        return agg[0] if single else agg

    def __call__(self, x):
        fast = self._single_point
        if fast is not None:
            if type(x) is np.ndarray:
                if x.ndim == 1 and x.shape[0] == self.n_inputs:
                    return fast(x.tolist())
            elif type(x) in (tuple, list) and len(x) == self.n_inputs and all(
                type(v) in (float, int) for v in x
            ):
                return fast(x)
        a, single = self.points(x)
        c = self._compiled
        if len(a) <= c.chunk:
            u = _defuzz(self._aggregate(c, a), c.y, self.defuzzification, c.y1)
        else:
            u = np.concatenate([_defuzz(self._aggregate(c, a[i:i + c.chunk]), c.y,
                                        self.defuzzification, c.y1)
                                for i in range(0, len(a), c.chunk)])
        return float(u[0]) if single else u

    def surface(self, grid: int = 81, refine: int = 4) -> Surface:
        """A precomputed ``grid`` x ``grid`` table with bilinear interpolation (two inputs only).

        Its ``max_error`` is measured against exact inference on a ``refine`` times finer grid
        (every cell's interior points) plus 4096 random points (fixed seed).
        """
        return make_surface(self, grid, refine)

    # ---------------------------------------------------------------- internals
    def _aggregate(self, c, a):
        w = _fire(c, a, self.and_method, self.or_method)
        imp, agg = self.implication, self.aggregation
        if agg == "max" or (agg == "sum" and imp == "prod"):
            # max_r imp(w_r, mu_k) = imp(max_r w_r, mu_k) for rules sharing output set k, and
            # sum_r w_r mu_k = (sum_r w_r) mu_k: reduce rules to one strength per output set.
            red = np.maximum if agg == "max" else np.add
            s = red.reduceat(w, c.starts, axis=1) if c.grouped else w
            if agg == "sum":
                return s @ c.curves
            cut = np.minimum(s[:, :, None], c.curves) if imp == "min" else s[:, :, None] * c.curves
            return cut.max(axis=1)
        curves = c.curves[c.rule_curve]
        cut = np.minimum(w[:, :, None], curves) if imp == "min" else w[:, :, None] * curves
        if agg == "sum":
            return cut.sum(axis=1)
        return 1.0 - np.prod(1.0 - cut, axis=1)

    @cached_property
    def _compiled(self) -> _Compiled:
        return _compile(self)

    @cached_property
    def _single_point(self):
        """A lean evaluator of one point for the common system shape (two or more inputs, all
        Gaussian sets, AND rules of weight 1, max aggregation, min or prod implication,
        discrete centroid), or None. The same arithmetic as the general path, without its
        array bookkeeping: an inner control loop evaluates one point at a time."""
        c = self._compiled
        if not (
            self.n_inputs > 1
            and len(c.groups) == 1
            and c.groups[0][1] is None
            and c.groups[0][0] is _k_gauss_fast
            and not c.extra
            and c.all_and
            and c.weights is None
            and self.aggregation == "max"
            and self.defuzzification == "centroid"
        ):
            return None
        _, _, (centre, k) = c.groups[0]
        col, gather, curves, y1 = c.col_input, c.gather, c.curves, c.y1
        starts = c.starts if c.grouped else None
        lo, hi = c.lo.tolist(), c.hi.tolist()
        land = np.minimum if self.and_method == "min" else np.multiply
        cut = np.minimum if self.implication == "min" else np.multiply
        mid = 0.5 * (float(c.y[0]) + float(c.y[-1]))

        def one(values) -> float:
            v = []
            for xi, a, b in zip(values, lo, hi):
                if xi != xi:
                    raise InputError(
                        "inputs", "NaN", "finite numbers (values beyond a range are saturated)"
                    )
                v.append(a if xi < a else b if xi > b else xi)
            d = np.array(v)[col] - centre
            g = np.exp(d * d * k)[gather]  # (n_inputs, R) memberships of each rule
            w = g[0]
            for i in range(1, len(g)):
                w = land(w, g[i])
            if starts is not None:
                w = np.maximum.reduceat(w, starts)  # one strength per output set
            num, den = cut(w[:, None], curves).max(axis=0) @ y1
            return float(num / den) if den > 0.0 else mid

        return one


def _check_rule(k: int, r: Rule, inputs, output) -> None:
    where = f"rule {k}"
    if len(r.antecedent) != len(inputs):
        raise InputError(f"{where} antecedent", list(r.antecedent),
                         f"needs one entry per input ({len(inputs)})")
    if len(r.negated) != len(inputs):
        raise InputError(f"{where} negated", list(r.negated), f"needs {len(inputs)} flags")
    for idx, var in zip(r.antecedent, inputs):
        if idx is not None and not (isinstance(idx, int | np.integer) and 0 <= idx < len(var.mfs)):
            raise InputError(f"{where} input {var.name!r} set", idx,
                             f"0..{len(var.mfs) - 1} or None (it has {len(var.mfs)} sets)")
    if not (isinstance(r.consequent, int | np.integer) and 0 <= r.consequent < len(output.mfs)):
        raise InputError(f"{where} output {output.name!r} set", r.consequent,
                         f"0..{len(output.mfs) - 1} (it has {len(output.mfs)} sets)")
    if not 0.0 <= r.weight <= 1.0:
        raise InputError(f"{where} weight", r.weight, "between 0 and 1")
    if r.connective not in ("and", "or"):
        raise InputError(f"{where} connective", r.connective, "'and' or 'or'")
    if all(i is None for i in r.antecedent):
        raise InputError(f"{where} antecedent", list(r.antecedent), "needs at least one set")


@dataclass(frozen=True, eq=False)
class _Compiled:
    """The FIS as arrays. Rules are held sorted by output curve (``order``; ``inverse`` undoes it)."""

    lo: np.ndarray
    hi: np.ndarray
    col_input: np.ndarray  # (M,) input of each membership column
    groups: tuple  # (kernel, columns or None for all, parameter arrays)
    extra: tuple  # which blocks follow mu in the gather table: "neg", "one", "zero"
    gather: np.ndarray  # (n_inputs, R) column per input and (sorted) rule
    conn_and: np.ndarray  # (R,) bool
    all_and: bool
    any_and: bool
    weights: np.ndarray | None
    curves: np.ndarray  # (K, res) output curves in use
    rule_curve: np.ndarray  # (R,) curve of each (sorted) rule
    starts: np.ndarray  # first sorted rule of each curve
    grouped: bool  # fewer curves than rules
    inverse: np.ndarray  # sorted position of each original rule
    y: np.ndarray
    y1: np.ndarray  # (res, 2): [y, 1], centroid numerator and denominator in one product
    chunk: int


def _compile(fis: FIS) -> _Compiled:
    cols, params_of, kinds, offset = [], [], [], []
    for i, var in enumerate(fis.inputs):
        offset.append(len(cols))
        for m in var.mfs:
            cols.append(i)
            kinds.append(m.kind)
            params_of.append(m.params)
    M, R = len(cols), len(fis.rules)
    groups = []
    for kind in dict.fromkeys(kinds):
        idx = np.array([j for j, k in enumerate(kinds) if k == kind])
        p = np.array([params_of[j] for j in idx]).T
        kernel = MF_KINDS[kind][0]
        if kind == "gaussmf":  # the hot path: exp(k (x - c)^2) with k = -1 / (2 sigma^2)
            kernel, p = _k_gauss_fast, np.array([p[1], -0.5 / p[0] ** 2])
        groups.append((kernel, None if len(idx) == M else idx, tuple(p)))
    y = fis.output_grid
    keys = list(dict.fromkeys((r.consequent, r.consequent_negated) for r in fis.rules))
    curves = np.array([fis.output.mfs[k](y) for k, _ in keys])
    for n, (_, negated) in enumerate(keys):
        if negated:
            curves[n] = 1.0 - curves[n]
    curve_of = np.array([keys.index((r.consequent, r.consequent_negated)) for r in fis.rules])
    order = np.argsort(curve_of, kind="stable")
    rules = [fis.rules[k] for k in order]
    neg = any(any(r.negated) for r in rules)
    dont = {(r.antecedent[i] is None, r.connective) for r in rules for i in range(fis.n_inputs)}
    extra = (("neg",) if neg else ()) + (("one",) if (True, "and") in dont else ()) + \
        (("zero",) if (True, "or") in dont else ())
    base = {"one": M * (1 + neg), "zero": M * (1 + neg) + ("one" in extra)}
    gather = np.empty((fis.n_inputs, R), dtype=np.intp)
    for r, rule in enumerate(rules):
        for i, idx in enumerate(rule.antecedent):
            if idx is None:
                gather[i, r] = base["one" if rule.connective == "and" else "zero"]
            else:
                gather[i, r] = offset[i] + idx + (M if rule.negated[i] else 0)
    weights = np.array([r.weight for r in rules])
    conn_and = np.array([r.connective == "and" for r in rules])
    rule_curve = curve_of[order]
    return _Compiled(
        lo=np.array([v.range[0] for v in fis.inputs]), hi=np.array([v.range[1] for v in fis.inputs]),
        col_input=np.array(cols), groups=tuple(groups), extra=extra, gather=gather,
        conn_and=conn_and, all_and=bool(conn_and.all()), any_and=bool(conn_and.any()),
        weights=None if np.all(weights == 1.0) else weights, curves=curves,
        rule_curve=rule_curve, starts=np.searchsorted(rule_curve, np.arange(len(keys))),
        grouped=len(keys) < R, inverse=np.argsort(order), y=y,
        y1=np.stack([y, np.ones_like(y)], axis=1),
        chunk=max(1, _CHUNK // (max(len(keys), R) * len(y))))


def _fire(c: _Compiled, a: np.ndarray, and_method: str, or_method: str) -> np.ndarray:
    """Firing strengths times weights, (n, R), rules in the compiled (sorted) order."""
    X = a[:, c.col_input]
    if len(c.groups) == 1 and c.groups[0][1] is None:
        kernel, _, p = c.groups[0]
        mu = kernel(X, *p)
    else:
        mu = np.empty_like(X)
        for kernel, idx, p in c.groups:
            mu[:, idx] = kernel(X[:, idx], *p)
    if c.extra:
        blocks = [mu]
        n = len(mu)
        for e in c.extra:
            blocks.append(1.0 - mu if e == "neg" else np.full((n, 1), 1.0 if e == "one" else 0.0))
        mu = np.concatenate(blocks, axis=1)
    g = mu[:, c.gather]  # (n, n_inputs, R)
    w_and = w_or = None
    if c.any_and:
        w_and = _fold(g, np.minimum if and_method == "min" else np.multiply)
    if not c.all_and:
        w_or = _fold(g, np.maximum) if or_method == "max" else 1.0 - _fold(1.0 - g, np.multiply)
    w = w_and if c.all_and else (w_or if not c.any_and else np.where(c.conn_and, w_and, w_or))
    return w if c.weights is None else w * c.weights


def _fold(g, op):
    """op-reduce (n, n_inputs, R) over the inputs (a loop over inputs, cheaper than a reduction)."""
    w = g[:, 0]
    for i in range(1, g.shape[1]):
        w = op(w, g[:, i])
    return w


def _defuzz(agg: np.ndarray, y: np.ndarray, method: str, y1=None) -> np.ndarray:
    """Defuzzify each row of ``agg`` (n, res) sampled on ``y``; all-zero rows -> mid-range."""
    if y1 is None:
        y1 = np.stack([y, np.ones_like(y)], axis=1)
    if method == "centroid":
        num, total = (agg @ y1).T
        if total.min() > 0.0:  # the usual case: one check instead of a masked division
            return num / total
        ok = total > 0.0
        u = num / np.where(ok, total, 1.0)
    elif method == "centroid_trapz":
        dy = np.diff(y)
        ya, yb = agg[:, :-1], agg[:, 1:]
        total = (0.5 * dy * (ya + yb)).sum(axis=1)
        moment = (dy * (0.5 * y[:-1] * (ya + yb) + dy * (ya + 2.0 * yb) / 6.0)).sum(axis=1)
        ok = total > 0.0
        u = moment / np.where(ok, total, 1.0)
    elif method == "bisector":
        cs = np.cumsum(agg, axis=1)
        total = cs[:, -1]
        u = y[np.argmax(cs >= 0.5 * total[:, None], axis=1)]
    else:
        total = agg.max(axis=1)
        at_max = agg == total[:, None]
        if method == "mom":
            u = (at_max @ y) / at_max.sum(axis=1)
        elif method == "som":
            u = y[np.argmax(at_max, axis=1)]
        else:  # lom
            u = y[len(y) - 1 - np.argmax(at_max[:, ::-1], axis=1)]
    if method not in ("centroid", "centroid_trapz"):
        ok = total > 0.0
    if not ok.all():
        mid = 0.5 * (y[0] + y[-1])
        log.debug("no rule fired for %d point(s); output set to mid-range %g", (~ok).sum(), mid)
        u = np.where(ok, u, mid)
    return u


# --------------------------------------------------------------------------- interpolated surface
@dataclass(frozen=True, eq=False)
class Surface:
    """A two-input FIS tabulated on a grid; ``surf(x)`` interpolates bilinearly.

    ``x0``, ``x1``: grid points of inputs 0 and 1 [their units]; ``u``: table (len(x0), len(x1))
    with ``u[i, j]`` the exact inference at (x0[i], x1[j]); ``max_error``: the largest
    |interpolated - exact| measured on a finer and a random off-grid sample [output unit];
    ``error_bound`` = ERROR_SAFETY x max_error, the stated bound: the worst error sits on thin
    ridges where the min/max operators switch rules, so a sample can miss it by a little (on the
    supervisor, 100,000 fresh random points exceeded the 4x-refined measurement by <= 13 %).
    Same call signature as the FIS; inputs are saturated to the grid, NaN raises InputError.
    """

    x0: np.ndarray
    x1: np.ndarray
    u: np.ndarray
    max_error: float
    n_checked: int

    @property
    def error_bound(self) -> float:
        return ERROR_SAFETY * self.max_error

    def __call__(self, x):
        a = np.asarray(x, dtype=float)
        single = a.ndim == 1
        if single and a.shape == (2,):
            a = a[None, :]
        if a.ndim != 2 or a.shape[1] != 2:
            raise InputError("inputs shape", np.asarray(x).shape, "(2,) or (n, 2) for a surface")
        if np.isnan(a).any():
            raise InputError("inputs", "NaN", "finite numbers (values beyond a range are saturated)")
        g0, g1 = len(self.x0), len(self.x1)
        t0 = (a[:, 0] - self.x0[0]) * ((g0 - 1) / (self.x0[-1] - self.x0[0]))
        t1 = (a[:, 1] - self.x1[0]) * ((g1 - 1) / (self.x1[-1] - self.x1[0]))
        t0 = np.minimum(np.maximum(t0, 0.0), g0 - 1)
        t1 = np.minimum(np.maximum(t1, 0.0), g1 - 1)
        i = np.minimum(t0.astype(np.intp), g0 - 2)
        j = np.minimum(t1.astype(np.intp), g1 - 2)
        f0, f1 = t0 - i, t1 - j
        flat = self.u.ravel()
        k = i * g1 + j
        top = flat[k] + f1 * (flat[k + 1] - flat[k])
        bot = flat[k + g1] + f1 * (flat[k + g1 + 1] - flat[k + g1])
        v = top + f0 * (bot - top)
        return float(v[0]) if single else v


def make_surface(fis: FIS, grid: int = 81, refine: int = 4, seed: int = 0) -> Surface:
    """Tabulate a two-input ``fis`` on ``grid`` x ``grid`` points and measure the error.

    ``max_error`` = max |bilinear - exact| over a ``refine``-times finer grid and 4096 random
    points (``seed``); it is a measured maximum, not a proven bound.
    """
    if fis.n_inputs != 2:
        raise InputError("surface inputs", fis.n_inputs, "a surface needs a two-input system")
    if isinstance(grid, bool) or int(grid) != grid or grid < 2:
        raise InputError("grid", grid, "a whole number of points >= 2")
    (a0, b0), (a1, b1) = fis.inputs[0].range, fis.inputs[1].range
    x0, x1 = np.linspace(a0, b0, int(grid)), np.linspace(a1, b1, int(grid))
    P = np.stack(np.meshgrid(x0, x1, indexing="ij"), axis=-1).reshape(-1, 2)
    table = fis(P).reshape(len(x0), len(x1))
    surf = Surface(x0, x1, table, 0.0, 0)
    f0 = np.linspace(a0, b0, (int(grid) - 1) * refine + 1)
    f1 = np.linspace(a1, b1, (int(grid) - 1) * refine + 1)
    Q = np.stack(np.meshgrid(f0, f1, indexing="ij"), axis=-1).reshape(-1, 2)
    rng = np.random.default_rng(seed)
    Q = np.concatenate([Q, rng.uniform([a0, a1], [b0, b1], size=(4096, 2))])
    err = float(np.max(np.abs(surf(Q) - fis(Q))))
    return replace(surf, max_error=err, n_checked=len(Q))
