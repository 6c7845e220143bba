"""The vectorised inference of a :class:`flexlift.fuzzy.FIS`: its arrays, compiled once.

A FIS is compiled into arrays (``_compile``): one membership column per input set, a gather
table giving each rule's antecedent column per input (NOT, don't care folded in as extra
columns), and per output a *plan*: which rules feed it and, for Mamdani, their output sets
sampled on the output grid; for Sugeno, the coefficients of its output functions. Evaluation
is then a few array operations over (points x rules [x grid]); no Python loop over points.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from flexlift.errors import InputError
from flexlift.fuzzy.mf import MF_KINDS, _k_gauss_fast

log = logging.getLogger("flexlift.fuzzy")

_CHUNK = 1 << 21  # elements per (points x sets x grid) block: bounds the memory of a batch


@dataclass(frozen=True, eq=False)
class _Plan:
    """One output's part of the compiled system. Its rules are columns of the firing matrix:
    ``cols`` (sorted by output set), or ``None`` for the first ``n_rules`` columns in order."""

    mid: float  # the middle of the output range: the output when none of its rules fires
    cols: np.ndarray | None
    n_rules: int
    # Mamdani
    y: np.ndarray | None = None  # output grid
    y1: np.ndarray | None = None  # (res, 2): [y, 1], centroid numerator and denominator
    curves: np.ndarray | None = None  # (K, res) output sets in use (NOT applied)
    rule_curve: np.ndarray | None = None  # (R_k,) curve of each of its rules
    starts: np.ndarray | None = None  # first rule of each curve
    grouped: bool = False  # fewer curves than rules
    # Sugeno
    coef: np.ndarray | None = None  # (K, n_inputs) linear coefficients (0 for constants)
    const: np.ndarray | None = None  # (K,)
    rule_fn: np.ndarray | None = None  # (R_k,) output function of each of its rules


@dataclass(frozen=True, eq=False)
class _Compiled:
    """The FIS as arrays. Rules are held sorted by output 0's sets (``inverse`` undoes it)."""

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
    inverse: np.ndarray  # sorted position of each original rule
    plans: tuple[_Plan, ...]
    chunk: int


def compile_fis(fis) -> _Compiled:
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
    keys = [[(c, n) for c, n in zip(r.consequents, r.consequents_negated)] for r in fis.rules]

    def members(k):  # output k's rules, grouped by output set in order of first appearance
        first: dict = {}
        for r in range(R):
            if keys[r][k][0] is not None:
                first.setdefault(keys[r][k], len(first))
        return sorted((r for r in range(R) if keys[r][k][0] is not None),
                      key=lambda r: first[keys[r][k]])

    feeding = [members(k) for k in range(fis.n_outputs)]
    order = feeding[0] + [r for r in range(R) if keys[r][0][0] is None]
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
    position = {rule: pos for pos, rule in enumerate(order)}
    plans = tuple(_plan(fis, k, [position[r] for r in feeding[k]], [keys[r][k] for r in feeding[k]])
                  for k in range(fis.n_outputs))
    width = max(max(len(p.curves) if p.curves is not None else 0, p.n_rules) for p in plans)
    res = fis.resolution if fis.kind == "mamdani" else 1
    return _Compiled(
        lo=np.array([v.range[0] for v in fis.inputs]), hi=np.array([v.range[1] for v in fis.inputs]),
        col_input=np.array(cols, dtype=np.intp), groups=tuple(groups), extra=extra,
        gather=gather, conn_and=conn_and, all_and=bool(conn_and.all()),
        any_and=bool(conn_and.any()), weights=None if np.all(weights == 1.0) else weights,
        inverse=np.argsort(order), plans=plans, chunk=max(1, _CHUNK // (max(width, 1) * res)))


def _plan(fis, k: int, cols: list[int], keys: list[tuple[int, bool]]) -> _Plan:
    var = fis.outputs[k]
    lo, hi = var.range
    in_order = cols == list(range(len(cols)))
    common = dict(mid=0.5 * (lo + hi), cols=None if in_order else np.array(cols, dtype=np.intp),
                  n_rules=len(cols))
    distinct = list(dict.fromkeys(keys))
    of_rule = np.array([distinct.index(key) for key in keys], dtype=np.intp)
    if fis.kind == "sugeno":
        coef = np.zeros((len(distinct), fis.n_inputs))
        const = np.zeros(len(distinct))
        for n, (j, _) in enumerate(distinct):
            m = var.mfs[j]
            if m.kind == "linear":
                coef[n], const[n] = m.params[:-1], m.params[-1]
            else:
                const[n] = m.params[0]
        return _Plan(**common, coef=coef, const=const, rule_fn=of_rule)
    y = fis.output_grids[k]
    curves = np.array([var.mfs[j](y) for j, _ in distinct]).reshape(len(distinct), len(y))
    for n, (_, negated) in enumerate(distinct):
        if negated:
            curves[n] = 1.0 - curves[n]
    return _Plan(**common, y=y, y1=np.stack([y, np.ones_like(y)], axis=1), curves=curves,
                 rule_curve=of_rule, starts=np.searchsorted(of_rule, np.arange(len(distinct))),
                 grouped=len(distinct) < len(cols))


# --------------------------------------------------------------------------- evaluation
def fire(c: _Compiled, a: np.ndarray, and_method: str, or_method: str) -> np.ndarray:
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
        w_or = _fold(g, np.maximum if or_method == "max" else _probor)
    w = w_and if c.all_and else (w_or if not c.any_and else np.where(c.conn_and, w_and, w_or))
    return w if c.weights is None else w * c.weights


def _probor(a, b):
    """MATLAB's probabilistic OR, a + b - ab (accurate for small a, b, unlike 1 - (1-a)(1-b))."""
    return a + b - a * b


def _fold(g, op):
    """op-reduce (n, n_inputs, R) over the inputs (a loop over inputs, cheaper than a reduction)."""
    w = g[:, 0]
    for i in range(1, g.shape[1]):
        w = op(w, g[:, i])
    return w


def _rules_of(p: _Plan, w: np.ndarray) -> np.ndarray:
    return w[:, :p.n_rules] if p.cols is None else w[:, p.cols]


def aggregate(p: _Plan, w: np.ndarray, implication: str, aggregation: str) -> np.ndarray:
    """The aggregated output set of one Mamdani output on its grid, (n, res)."""
    if p.n_rules == 0:
        return np.zeros((len(w), len(p.y)))
    w = _rules_of(p, w)
    if aggregation == "max" or (aggregation == "sum" and implication == "prod"):
        # max_r imp(w_r, mu_k) = imp(max_r w_r, mu_k) for rules sharing output set k, and
        # sum_r w_r mu_k = (sum_r w_r) mu_k: reduce rules to one strength per output set.
        red = np.maximum if aggregation == "max" else np.add
        s = red.reduceat(w, p.starts, axis=1) if p.grouped else w
        if aggregation == "sum":
            return s @ p.curves
        cut = np.minimum(s[:, :, None], p.curves) if implication == "min" \
            else s[:, :, None] * p.curves
        return cut.max(axis=1)
    curves = p.curves[p.rule_curve]
    cut = np.minimum(w[:, :, None], curves) if implication == "min" else w[:, :, None] * curves
    if aggregation == "sum":
        return cut.sum(axis=1)
    return _fold(cut, _probor)


def sugeno(p: _Plan, w: np.ndarray, a: np.ndarray, method: str) -> np.ndarray:
    """One Sugeno output: weighted average (wtaver) or sum (wtsum) of its rules' outputs."""
    if p.n_rules == 0:
        return np.full(len(w), p.mid)
    w = _rules_of(p, w)
    f = a[:, :1] * p.coef[:, 0]  # (n, K) every output function at every point; a plain
    for i in range(1, a.shape[1]):  # loop, not a matrix product: the same sums for any n
        f = f + a[:, i:i + 1] * p.coef[:, i]
    z = (f + p.const)[:, p.rule_fn]  # (n, R_k) each rule's output
    num = (w * z).sum(axis=1)
    total = w.sum(axis=1)
    ok = total > 0.0
    if ok.all():
        return num / total if method == "wtaver" else num
    log.debug("no rule fired for %d point(s); output set to mid-range %g", (~ok).sum(), p.mid)
    u = num / np.where(ok, total, 1.0) if method == "wtaver" else num
    return np.where(ok, u, p.mid)


def defuzzify(agg: np.ndarray, p: _Plan, method: str) -> np.ndarray:
    """Defuzzify each row of ``agg`` (n, res) on the plan's grid; all-zero rows -> mid-range."""
    y, y1 = p.y, p.y1
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
        log.debug("no rule fired for %d point(s); output set to mid-range %g", (~ok).sum(), p.mid)
        u = np.where(ok, u, p.mid)
    return u


def evaluate(fis, c: _Compiled, a: np.ndarray) -> np.ndarray:
    """Every output at every point of ``a`` (n, n_inputs), shape (n, n_outputs)."""
    out = np.empty((len(a), len(c.plans)))
    for i in range(0, len(a), c.chunk):
        block = a[i:i + c.chunk]
        w = fire(c, block, fis.and_method, fis.or_method)
        for k, p in enumerate(c.plans):
            if fis.kind == "sugeno":
                out[i:i + c.chunk, k] = sugeno(p, w, block, fis.defuzzification)
            else:
                agg = aggregate(p, w, fis.implication, fis.aggregation)
                out[i:i + c.chunk, k] = defuzzify(agg, p, fis.defuzzification)
    return out


def single_point(fis, c: _Compiled):
    """A lean evaluator of one point for the common system shape (two or more inputs, all
    Gaussian sets, AND rules of weight 1, one Mamdani output fed by every rule, max
    aggregation, min or prod implication, discrete centroid, saturated inputs), or None. The
    same arithmetic as the general path, without its array bookkeeping: an inner control loop
    evaluates one point at a time."""
    if not (
        fis.kind == "mamdani"
        and fis.n_inputs > 1
        and len(c.plans) == 1
        and c.plans[0].cols is None
        and c.plans[0].n_rules == len(fis.rules)
        and fis.out_of_range == "clip"
        and len(c.groups) == 1
        and c.groups[0][1] is None
        and c.groups[0][0] is _k_gauss_fast
        and not c.extra
        and c.all_and
        and c.weights is None
        and fis.aggregation == "max"
        and fis.defuzzification == "centroid"
    ):
        return None
    _, _, (centre, k) = c.groups[0]
    p = c.plans[0]
    col, gather, curves, y1 = c.col_input, c.gather, p.curves, p.y1
    starts = p.starts if p.grouped else None
    lo, hi = c.lo.tolist(), c.hi.tolist()
    land = np.minimum if fis.and_method == "min" else np.multiply
    cut = np.minimum if fis.implication == "min" else np.multiply
    mid = p.mid

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
