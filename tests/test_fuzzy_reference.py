"""The vectorised engine against the plain reference evaluator on random systems: every MF
type, Mamdani and Sugeno, one to three outputs, NOT, OR, don't care, weights, every operator
and defuzzifier, inputs inside and beyond their ranges (clipped or, as MATLAB, not)."""

import numpy as np
import pytest
from fis_reference import evaluate

from flexlift.fuzzy.system import (
    AGGREGATIONS,
    AND_METHODS,
    FIS,
    IMPLICATIONS,
    MF,
    MF_KINDS,
    OR_METHODS,
    Rule,
    Variable,
)

KINDS = sorted(MF_KINDS)


def _random_set(rng, kind, lo, hi, name):
    span = hi - lo
    n = len(MF_KINDS[kind][1])
    p = np.sort(rng.uniform(lo - 0.2 * span, hi + 0.2 * span, n))
    if kind == "gaussmf":
        p = [rng.uniform(0.05, 0.5) * span, rng.uniform(lo, hi)]
    elif kind == "gauss2mf":
        c1, c2 = np.sort(rng.uniform(lo, hi, 2))
        p = [rng.uniform(0.05, 0.4) * span, c1, rng.uniform(0.05, 0.4) * span, c2]
    elif kind == "gbellmf":
        p = [rng.uniform(0.1, 0.5) * span, rng.uniform(0.5, 4), rng.uniform(lo, hi)]
    elif kind in ("sigmf", "dsigmf", "psigmf"):
        p = [rng.choice([-1, 1]) * rng.uniform(2, 20) / span if i % 2 == 0 else p[i]
             for i in range(n)]
    elif kind in ("smf", "zmf") and rng.random() < 0.2:
        p = p[::-1]  # a >= b: MATLAB's step
    return MF(name, kind, tuple(float(v) for v in p))


def _random_system(seed):
    rng = np.random.default_rng(seed)
    kind = "sugeno" if rng.random() < 0.4 else "mamdani"
    n_in, n_out = int(rng.integers(1, 5)), int(rng.integers(1, 4))
    inputs = []
    for i in range(n_in):
        lo = float(rng.uniform(-5, 5))
        hi = lo + float(rng.uniform(0.5, 10))
        count = int(rng.integers(0 if i else 1, 5))
        inputs.append(Variable(f"x{i}", (lo, hi), tuple(
            _random_set(rng, KINDS[rng.integers(len(KINDS))], lo, hi, f"s{j}")
            for j in range(count))))
    outputs = []
    for k in range(n_out):
        lo = float(rng.uniform(-5, 5))
        hi = lo + float(rng.uniform(0.5, 10))
        if kind == "sugeno":
            mfs = tuple(MF(f"f{j}", "linear", tuple(rng.uniform(-2, 2, n_in + 1)))
                        if rng.random() < 0.6 else MF(f"f{j}", "constant", (rng.uniform(lo, hi),))
                        for j in range(int(rng.integers(1, 4))))
        else:
            mfs = tuple(_random_set(rng, KINDS[rng.integers(len(KINDS))], lo, hi, f"o{j}")
                        for j in range(int(rng.integers(1, 5))))
        outputs.append(Variable(f"y{k}", (lo, hi), mfs))
    rules = []
    for _ in range(int(rng.integers(1, 13))):
        ante = [int(rng.integers(len(v.mfs))) if v.mfs and rng.random() < 0.8 else None
                for v in inputs]
        if all(a is None for a in ante):
            ante[0] = int(rng.integers(len(inputs[0].mfs)))
        cons = tuple(int(rng.integers(len(v.mfs))) if rng.random() < 0.85 else None
                     for v in outputs)
        rules.append(Rule(tuple(ante), cons, weight=float(rng.choice([1.0, rng.uniform(0, 1)])),
                          connective="or" if rng.random() < 0.3 else "and",
                          negated=tuple(bool(rng.random() < 0.2) for _ in inputs),
                          consequent_negated=tuple(kind == "mamdani" and bool(rng.random() < 0.1)
                                                   for _ in outputs)))
    aggregation = str(rng.choice(AGGREGATIONS))
    if kind == "sugeno":
        defuzz = str(rng.choice(["wtaver", "wtsum"]))
    elif aggregation == "max":  # the tie-sensitive methods only where the curves are exact
        defuzz = str(rng.choice(["centroid", "bisector", "mom", "som", "lom"]))
    else:
        defuzz = "centroid"
    return FIS(f"random{seed}", tuple(inputs), tuple(outputs), tuple(rules), kind=kind,
               and_method=str(rng.choice(AND_METHODS)), or_method=str(rng.choice(OR_METHODS)),
               implication=str(rng.choice(IMPLICATIONS)), aggregation=aggregation,
               defuzzification=defuzz, resolution=int(rng.integers(11, 102)),
               out_of_range=str(rng.choice(["clip", "extrapolate"])))


@pytest.mark.parametrize("seed", range(60))
def test_random_system_matches_the_reference(seed):
    fis = _random_system(seed)
    rng = np.random.default_rng(1000 + seed)
    lo = np.array([v.range[0] for v in fis.inputs])
    hi = np.array([v.range[1] for v in fis.inputs])
    pts = rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), (25, fis.n_inputs))
    ref = np.array([evaluate(fis, p, clip=fis.out_of_range == "clip") for p in pts])
    ours = np.asarray(fis(pts)).reshape(len(pts), -1)
    scale = np.maximum(np.array([v.range[1] - v.range[0] for v in fis.outputs]), np.abs(ref))
    np.testing.assert_array_less(np.abs(ours - ref), 1e-12 * scale + 1e-300,
                                 err_msg=f"{fis.kind} {fis.defuzzification} {fis.aggregation}")
    one = np.asarray(fis(pts[0])).reshape(-1)  # a single point: the same numbers (to rounding)
    np.testing.assert_array_less(np.abs(one - ours[0]), 1e-13 * scale[0])


def test_the_random_systems_cover_every_feature():
    systems = [_random_system(s) for s in range(60)]
    rules = [r for f in systems for r in f.rules]
    assert {f.kind for f in systems} == {"mamdani", "sugeno"}
    assert {f.n_outputs for f in systems} == {1, 2, 3}
    assert {m.kind for f in systems for v in (*f.inputs, *f.outputs) for m in v.mfs} == {
        *MF_KINDS, "constant", "linear"}
    assert {f.defuzzification for f in systems} == {"centroid", "bisector", "mom", "som", "lom",
                                                    "wtaver", "wtsum"}
    for fld, values in (("and_method", AND_METHODS), ("or_method", OR_METHODS),
                        ("implication", IMPLICATIONS), ("aggregation", AGGREGATIONS),
                        ("out_of_range", ("clip", "extrapolate"))):
        assert {getattr(f, fld) for f in systems if f.kind == "mamdani"} == set(values), fld
    assert any(r.connective == "or" for r in rules) and any(any(r.negated) for r in rules)
    assert any(None in r.antecedent for r in rules) and any(None in r.consequents for r in rules)
    assert any(r.weight < 1 for r in rules) and any(any(r.consequents_negated) for r in rules)
