"""A small, pure, vectorised fuzzy inference engine with the semantics of MATLAB's ``evalfis``.

A :class:`FIS` is immutable data (input/output :class:`Variable` s with their membership
functions, :class:`Rule` s as index tuples, the operator names); evaluating it is one pure call,
``u = fis(x)``, for one point or an array of points, vectorised with NumPy over points and
rules (no Python loop over points, no set-input/compute/read-output state). Membership
functions: :mod:`flexlift.fuzzy.mf`; the compiled arrays: :mod:`flexlift.fuzzy.engine`.

Semantics (MATLAB's Fuzzy Logic Toolbox, type-1 ``mamfis``/``sugfis``, as ``evalfis`` computes):

- firing strength of a rule = AND (min | prod) or OR (max | probor) of its antecedent
  memberships, times the rule weight (in [0, 1]). A negated antecedent (NOT, a negative index
  in a .fis file) uses 1 - mu; a "don't care" (``None``, 0 in a file) counts as 1 in an AND
  rule and 0 in an OR rule, i.e. it drops out.
- Mamdani: implication (min | prod) of each rule's strength with its output set sampled on
  ``resolution`` evenly spaced points of the output range (default 101, MATLAB's
  NumSamplePoints); a negated consequent uses 1 - mu; aggregation (max | sum | probor) over
  the rules of that output (a consequent of ``None``/0 leaves the rule out of that output);
  defuzzification ``centroid`` is MATLAB's discrete sum(y mu) / sum(mu) over the grid;
  ``bisector`` the first grid point where the running sum reaches half the total; ``mom``,
  ``som``, ``lom`` the mean, smallest and largest grid value where the curve is at its maximum
  (the current MATLAB definition; some old releases took the smallest/largest *absolute*
  value). ``centroid_trapz`` (not MATLAB's) is the piecewise-linear centroid of the sampled
  curve, equal to ``skfuzzy.defuzz(y, mu, "centroid")``.
- Sugeno: each output set is a function of the inputs, ``constant`` [c] or ``linear``
  [a1 .. an c] = a1 x1 + ... + an xn + c; the output is ``wtaver`` sum(w z) / sum(w) or
  ``wtsum`` sum(w z) over the rules of that output (w: firing strength times weight, z: the
  rule's output function at the input). Implication and aggregation are not used (MATLAB's
  sugfis fixes them to prod and sum, which is this formula); negated consequents are refused.
- No rule fired: an output whose rules all have zero strength (zero aggregated area, or
  sum(w) = 0) is the middle of its range, as MATLAB (which also warns; we log at DEBUG).
- Inputs outside an input's range: ``out_of_range="clip"`` (default) saturates them to the
  range before evaluation, which a controller wants. MATLAB does not clip: it warns and
  evaluates the membership functions at the given value, so sets that end at the range's
  edge do not fire (a "no rules fired" answer); ``out_of_range="extrapolate"`` does the same.
  NaN raises InputError either way.

Shapes: ``x`` (n_inputs,) -> a float for a one-output system, (n_outputs,) otherwise;
(n, n_inputs) -> (n,) or (n, n_outputs). A one-input system also takes a scalar or shape (n,).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from flexlift.errors import InputError
from flexlift.fuzzy.engine import (
    aggregate,
    compile_fis,
    evaluate,
    fire,
    single_point,
)
from flexlift.fuzzy.mf import (  # noqa: F401  (re-exported: the public names of this module)
    ALL_KINDS,
    MF_KINDS,
    OUTPUT_FUNCTIONS,
    check_mf,
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
from flexlift.fuzzy.surface import ERROR_SAFETY, Surface, make_surface  # noqa: F401

KINDS = ("mamdani", "sugeno")
AND_METHODS = ("min", "prod")
OR_METHODS = ("max", "probor")
IMPLICATIONS = ("min", "prod")
AGGREGATIONS = ("max", "sum", "probor")
DEFUZZIFICATIONS = ("centroid", "centroid_trapz", "bisector", "mom", "som", "lom")
SUGENO_DEFUZZIFICATIONS = ("wtaver", "wtsum")
OUT_OF_RANGE = ("clip", "extrapolate")


# --------------------------------------------------------------------------- data
@dataclass(frozen=True)
class MF:
    """A named membership function: ``kind`` (see :mod:`flexlift.fuzzy.mf`) and MATLAB-order
    ``params``. Calling it evaluates the set at ``x`` (its variable's unit); a Sugeno output
    function (``constant``, ``linear``) is evaluated at input vectors ``x`` of shape
    (..., n_inputs) instead."""

    name: str
    kind: str
    params: tuple[float, ...]

    def __post_init__(self):
        object.__setattr__(self, "params", check_mf(self.kind, self.params, f"set {self.name!r}"))

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        if self.kind == "constant":
            return np.full(x.shape[:-1] if x.ndim else (), self.params[0])
        if self.kind == "linear":
            return x @ np.array(self.params[:-1]) + self.params[-1]
        return MF_KINDS[self.kind][0](x, *self.params)


@dataclass(frozen=True)
class Variable:
    """A linguistic variable: name, range (lo, hi) [its unit] and its membership functions
    (an input may have none: a Sugeno system can use it in its linear output functions only)."""

    name: str
    range: tuple[float, float]
    mfs: tuple[MF, ...]

    def __post_init__(self):
        lo, hi = (float(v) for v in self.range)
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise InputError(f"variable {self.name!r} range", [lo, hi], "needs finite lo < hi")
        object.__setattr__(self, "range", (lo, hi))
        object.__setattr__(self, "mfs", tuple(self.mfs))

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(m.name for m in self.mfs)


@dataclass(frozen=True)
class Rule:
    """IF input_i is set antecedent[i] (AND|OR ...) THEN output_k is set consequent[k].

    Indices are 0-based into each variable's ``mfs``; ``None`` means "don't care" in the
    antecedent and "not in this rule" in the consequent. ``consequent`` is an int for a
    one-output system, a tuple (one entry per output) otherwise; ``consequents`` is always the
    tuple. ``negated[i]`` (default all False) uses NOT (1 - mu); ``consequent_negated`` likewise
    (a bool, or a tuple per output); ``weight`` in [0, 1].
    """

    antecedent: tuple[int | None, ...]
    consequent: int | None | tuple[int | None, ...]
    weight: float = 1.0
    connective: str = "and"
    negated: tuple[bool, ...] = ()
    consequent_negated: bool | tuple[bool, ...] = False

    def __post_init__(self):
        object.__setattr__(self, "antecedent", tuple(self.antecedent))
        object.__setattr__(self, "negated", tuple(bool(v) for v in self.negated)
                           or (False,) * len(self.antecedent))
        cons = self.consequent
        if isinstance(cons, tuple | list):
            cons = tuple(cons)
            if len(cons) == 1:
                cons = cons[0]
        object.__setattr__(self, "consequent", cons)
        neg = self.consequent_negated
        n = len(cons) if isinstance(cons, tuple) else 1
        neg = tuple(bool(v) for v in neg) if isinstance(neg, tuple | list) else (bool(neg),) * n
        object.__setattr__(self, "consequent_negated", neg[0] if n == 1 and len(neg) == 1 else neg)

    @property
    def consequents(self) -> tuple[int | None, ...]:
        return self.consequent if isinstance(self.consequent, tuple) else (self.consequent,)

    @property
    def consequents_negated(self) -> tuple[bool, ...]:
        neg = self.consequent_negated
        return neg if isinstance(neg, tuple) else (neg,) * len(self.consequents)


@dataclass(frozen=True)
class FIS:
    """A fuzzy inference system, Mamdani or Sugeno, one or more outputs. Call it: ``u = fis(x)``.

    ``outputs`` takes one :class:`Variable` (a one-output system, the common case) or a tuple
    of them. ``kind`` "mamdani" | "sugeno"; a Sugeno system's outputs hold ``constant`` or
    ``linear`` functions and ``defuzzification`` is "wtaver" or "wtsum". ``resolution``: points
    of each Mamdani output grid (MATLAB's NumSamplePoints, default 101). ``out_of_range``:
    "clip" (saturate inputs to their ranges, the default) or "extrapolate" (MATLAB).
    """

    name: str
    inputs: tuple[Variable, ...]
    outputs: tuple[Variable, ...]
    rules: tuple[Rule, ...]
    and_method: str = "min"
    or_method: str = "max"
    implication: str = "min"
    aggregation: str = "max"
    defuzzification: str = "centroid"
    resolution: int = 101
    kind: str = "mamdani"
    out_of_range: str = "clip"

    def __post_init__(self):
        outs = (self.outputs,) if isinstance(self.outputs, Variable) else tuple(self.outputs)
        object.__setattr__(self, "inputs", tuple(self.inputs))
        object.__setattr__(self, "outputs", outs)
        object.__setattr__(self, "rules", tuple(self.rules))
        if self.kind not in KINDS:
            raise InputError("kind", self.kind, f"allowed: {', '.join(KINDS)}")
        defuzz = SUGENO_DEFUZZIFICATIONS if self.kind == "sugeno" else DEFUZZIFICATIONS
        for fld, allowed in (("and_method", AND_METHODS), ("or_method", OR_METHODS),
                             ("implication", IMPLICATIONS), ("aggregation", AGGREGATIONS),
                             ("defuzzification", defuzz), ("out_of_range", OUT_OF_RANGE)):
            if getattr(self, fld) not in allowed:
                raise InputError(fld, getattr(self, fld), f"allowed: {', '.join(allowed)}")
        if isinstance(self.resolution, bool) or int(self.resolution) != self.resolution \
                or self.resolution < 3:
            raise InputError("resolution", self.resolution, "a whole number of points >= 3")
        object.__setattr__(self, "resolution", int(self.resolution))
        if not self.inputs:
            raise InputError("inputs", 0, "needs at least one input variable")
        if not outs:
            raise InputError("outputs", 0, "needs at least one output variable")
        for var in outs:
            _check_output(var, self.kind, self.n_inputs)
        if not self.rules:
            raise InputError("rules", 0, "needs at least one rule")
        for k, r in enumerate(self.rules, 1):
            _check_rule(k, r, self)

    # ---------------------------------------------------------------- shape
    @property
    def n_inputs(self) -> int:
        return len(self.inputs)

    @property
    def n_outputs(self) -> int:
        return len(self.outputs)

    @property
    def output(self) -> Variable:
        """The output variable of a one-output system."""
        if len(self.outputs) != 1:
            raise InputError("output", f"{len(self.outputs)} outputs",
                             "this system has several outputs: use .outputs")
        return self.outputs[0]

    @cached_property
    def output_grids(self) -> tuple[np.ndarray, ...]:
        """Each output universe's sample points (``resolution`` of them) [output unit]."""
        return tuple(np.linspace(*v.range, self.resolution) for v in self.outputs)

    @property
    def output_grid(self) -> np.ndarray:
        """The output universe's sample points of a one-output system [output unit]."""
        self.output  # noqa: B018  (raises for a system with several outputs)
        return self.output_grids[0]

    def with_options(self, **changes) -> FIS:
        """A copy with operators changed, e.g. ``fis.with_options(defuzzification="mom")``."""
        return replace(self, **changes)

    # ---------------------------------------------------------------- evaluation
    def points(self, x) -> tuple[np.ndarray, bool]:
        """Inputs as an (n, n_inputs) array (saturated unless ``out_of_range="extrapolate"``),
        and whether a single point was given."""
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
        if self.out_of_range == "extrapolate":
            return a, single
        c = self._compiled
        return np.minimum(np.maximum(a, c.lo), c.hi), single

    def firing_strengths(self, x) -> np.ndarray:
        """Rule firing strengths times weights, shape (n, n_rules) (or (n_rules,) for one point)."""
        a, single = self.points(x)
        c = self._compiled
        w = fire(c, a, self.and_method, self.or_method)[:, c.inverse]
        return w[0] if single else w

    def aggregate(self, x) -> np.ndarray:
        """The aggregated output sets of a Mamdani system on its output grids: (n, resolution)
        for one output, (n, n_outputs, resolution) for several (without the n for one point)."""
        if self.kind != "mamdani":
            raise InputError("aggregate", self.kind, "only a Mamdani system has output sets")
        a, single = self.points(x)
        c = self._compiled
        parts = []
        for i in range(0, max(len(a), 1), c.chunk):
            w = fire(c, a[i:i + c.chunk], self.and_method, self.or_method)
            parts.append(np.stack([aggregate(p, w, self.implication, self.aggregation)
                                   for p in c.plans], axis=1))
        agg = np.concatenate(parts)
        if self.n_outputs == 1:
            agg = agg[:, 0]
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
        u = evaluate(self, self._compiled, a)
        if self.n_outputs == 1:
            u = u[:, 0]
            return float(u[0]) if single else u
        return u[0] if single else u

    def surface(self, grid: int = 81, refine: int = 4) -> Surface:
        """A precomputed ``grid`` x ``grid`` table with bilinear interpolation (two inputs, one
        output). Its ``max_error`` is measured against exact inference on a ``refine`` times
        finer grid (every cell's interior points) plus 4096 random points (fixed seed)."""
        return make_surface(self, grid, refine)

    # ---------------------------------------------------------------- internals
    def __getstate__(self) -> dict:
        """Pickled (to a figure process, say) without what it derives and caches, rebuilt
        on demand: the fast one-point evaluator is a local function, which does not pickle."""
        derived = ("_compiled", "_single_point", "output_grids")
        return {k: v for k, v in self.__dict__.items() if k not in derived}

    @cached_property
    def _compiled(self):
        return compile_fis(self)

    @cached_property
    def _single_point(self):
        return single_point(self, self._compiled)


def _check_output(var: Variable, kind: str, n_inputs: int) -> None:
    where = f"output {var.name!r}"
    if not var.mfs:
        raise InputError(f"{where} sets", 0, "needs at least one set")
    for m in var.mfs:
        function = m.kind in ("constant", "linear")
        if kind == "mamdani" and function:
            raise InputError(f"{where} set {m.name!r}", m.kind,
                             "constant and linear output functions need a Sugeno system")
        if kind == "sugeno" and not function:
            raise InputError(f"{where} set {m.name!r}", m.kind,
                             "a Sugeno output takes constant or linear functions")
        if m.kind == "linear" and len(m.params) != n_inputs + 1:
            raise InputError(f"{where} set {m.name!r} parameters", list(m.params),
                             f"linear takes {n_inputs + 1}: one coefficient per input and c")


def _check_rule(k: int, r: Rule, fis: FIS) -> None:
    where = f"rule {k}"
    inputs, outputs = fis.inputs, fis.outputs
    if len(r.antecedent) != len(inputs):
        raise InputError(f"{where} antecedent", list(r.antecedent),
                         f"needs one entry per input ({len(inputs)})")
    if len(r.negated) != len(inputs):
        raise InputError(f"{where} negated", list(r.negated), f"needs {len(inputs)} flags")
    for idx, var in zip(r.antecedent, inputs):
        if idx is not None and not (isinstance(idx, int | np.integer) and 0 <= idx < len(var.mfs)):
            raise InputError(f"{where} input {var.name!r} set", idx,
                             f"0..{len(var.mfs) - 1} or None (it has {len(var.mfs)} sets)")
    if len(r.consequents) != len(outputs) or len(r.consequents_negated) != len(outputs):
        raise InputError(f"{where} consequent", r.consequent,
                         f"needs one entry per output ({len(outputs)})")
    for idx, neg, var in zip(r.consequents, r.consequents_negated, outputs):
        if idx is not None and not (isinstance(idx, int | np.integer) and 0 <= idx < len(var.mfs)):
            raise InputError(f"{where} output {var.name!r} set", idx,
                             f"0..{len(var.mfs) - 1} (it has {len(var.mfs)} sets)")
        if neg and fis.kind == "sugeno":
            raise InputError(f"{where} output {var.name!r}", "NOT",
                             "a Sugeno system cannot negate a consequent")
    if not 0.0 <= r.weight <= 1.0:
        raise InputError(f"{where} weight", r.weight, "between 0 and 1")
    if r.connective not in ("and", "or"):
        raise InputError(f"{where} connective", r.connective, "'and' or 'or'")
    if all(i is None for i in r.antecedent):
        raise InputError(f"{where} antecedent", list(r.antecedent), "needs at least one set")
