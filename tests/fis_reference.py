"""A slow, obvious reference evaluator of MATLAB's evalfis semantics, for the tests.

Written plainly from the Fuzzy Logic Toolbox documentation, independently of flexlift's
engine: scalar Python (``math``), one point at a time, loops over rules and grid points, every
membership function a chain of ifs. It reads flexlift's FIS data only for the numbers in it
(sets, rules, operators). Use :func:`evaluate` for one point (a list of outputs).
"""

from __future__ import annotations

import math


def sig(x, a, c):
    return 1.0 / (1.0 + math.exp(-a * (x - c)))


def s_curve(x, a, b):
    if a >= b:
        return 1.0 if x >= (a + b) / 2 else 0.0
    if x <= a:
        return 0.0
    if x <= (a + b) / 2:
        return 2 * ((x - a) / (b - a)) ** 2
    if x <= b:
        return 1 - 2 * ((x - b) / (b - a)) ** 2
    return 1.0


def z_curve(x, a, b):
    if a >= b:
        return 1.0 if x <= (a + b) / 2 else 0.0
    if x <= a:
        return 1.0
    if x <= (a + b) / 2:
        return 1 - 2 * ((x - a) / (b - a)) ** 2
    if x <= b:
        return 2 * ((x - b) / (b - a)) ** 2
    return 0.0


def membership(kind, p, x):
    """mu(x) of one set, MATLAB's formula for ``kind`` with parameters ``p``."""
    if kind == "trimf":
        a, b, c = p
        if x < a or x > c:
            return 0.0
        if x < b:
            return (x - a) / (b - a)
        if x == b:
            return 1.0
        return (c - x) / (c - b)
    if kind == "trapmf":
        a, b, c, d = p
        if x < a or x > d:
            return 0.0
        if x < b:
            return (x - a) / (b - a)
        if x <= c:
            return 1.0
        return (d - x) / (d - c)
    if kind == "gaussmf":
        s, c = p
        return math.exp(-((x - c) ** 2) / (2 * s ** 2))
    if kind == "gauss2mf":
        s1, c1, s2, c2 = p
        left = math.exp(-((x - c1) ** 2) / (2 * s1 ** 2)) if x < c1 else 1.0
        right = math.exp(-((x - c2) ** 2) / (2 * s2 ** 2)) if x > c2 else 1.0
        return left * right
    if kind == "gbellmf":
        a, b, c = p
        return 1 / (1 + abs((x - c) / a) ** (2 * b))
    if kind == "sigmf":
        return sig(x, *p)
    if kind == "dsigmf":
        return abs(sig(x, p[0], p[1]) - sig(x, p[2], p[3]))
    if kind == "psigmf":
        return sig(x, p[0], p[1]) * sig(x, p[2], p[3])
    if kind == "smf":
        return s_curve(x, *p)
    if kind == "zmf":
        return z_curve(x, *p)
    if kind == "pimf":
        return s_curve(x, p[0], p[1]) * z_curve(x, p[2], p[3])
    if kind == "linsmf":
        a, b = p
        if a == b:
            return 1.0 if x >= a else 0.0
        return min(1.0, max(0.0, (x - a) / (b - a)))
    if kind == "linzmf":
        a, b = p
        if a == b:
            return 1.0 if x < a else 0.0
        return min(1.0, max(0.0, (b - x) / (b - a)))
    raise ValueError(kind)


T_NORM = {"min": min, "prod": lambda a, b: a * b}
S_NORM = {"max": max, "probor": lambda a, b: a + b - a * b, "sum": lambda a, b: a + b}


def strengths(fis, x):
    """Each rule's firing strength times its weight."""
    out = []
    for rule in fis.rules:
        mus = []
        for i, (idx, neg) in enumerate(zip(rule.antecedent, rule.negated)):
            if idx is None:
                mus.append(1.0 if rule.connective == "and" else 0.0)
                continue
            m = fis.inputs[i].mfs[idx]
            mu = membership(m.kind, m.params, x[i])
            mus.append(1 - mu if neg else mu)
        op = T_NORM[fis.and_method] if rule.connective == "and" else S_NORM[fis.or_method]
        w = mus[0]
        for mu in mus[1:]:
            w = op(w, mu)
        out.append(w * rule.weight)
    return out


def defuzzify(method, y, mu, mid):
    total = sum(mu)
    if max(mu) <= 0:
        return mid
    if method == "centroid":
        return sum(a * b for a, b in zip(y, mu)) / total
    if method == "bisector":
        run = 0.0
        for yj, m in zip(y, mu):
            run += m
            if run >= total / 2:
                return yj
    top = max(mu)
    at = [yj for yj, m in zip(y, mu) if m == top]
    return {"mom": sum(at) / len(at), "som": at[0], "lom": at[-1]}[method]


def evaluate(fis, point, clip=True):
    """MATLAB's evalfis at one point: the list of outputs."""
    x = list(point)
    if clip:
        x = [min(max(v, var.range[0]), var.range[1]) for v, var in zip(x, fis.inputs)]
    w = strengths(fis, x)
    outputs = []
    for k, var in enumerate(fis.outputs):
        lo, hi = var.range
        mid = (lo + hi) / 2
        mine = [(wr, r.consequents[k], r.consequents_negated[k])
                for wr, r in zip(w, fis.rules) if r.consequents[k] is not None]
        if fis.kind == "sugeno":
            num = den = 0.0
            for wr, j, _ in mine:
                m = var.mfs[j]
                z = m.params[0] if m.kind == "constant" else \
                    sum(a * xi for a, xi in zip(m.params, x)) + m.params[-1]
                num += wr * z
                den += wr
            if den == 0:
                outputs.append(mid)
            else:
                outputs.append(num / den if fis.defuzzification == "wtaver" else num)
            continue
        n = fis.resolution
        y = [lo + j * (hi - lo) / (n - 1) for j in range(n)]
        agg = []
        for yj in y:
            value = None
            for wr, j, neg in mine:
                m = var.mfs[j]
                mu = membership(m.kind, m.params, yj)
                cut = T_NORM[fis.implication](wr, 1 - mu if neg else mu)
                value = cut if value is None else S_NORM[fis.aggregation](value, cut)
            agg.append(0.0 if value is None else value)
        outputs.append(defuzzify(fis.defuzzification, y, agg, mid))
    return outputs
