"""Which uncertainty matters: Sobol' first-order and total indices, by SALib.

A sweep's ``method: sobol`` is Saltelli's design (``SALib.sample.sobol``, scrambled Sobol'
sequence, no second-order terms): N base samples, each followed by one row per group with that
group's values taken from a second matrix, and the second matrix's own row: N x (groups + 2)
cases, in the unit cube (each variable's law maps it, :meth:`Distribution.ppf`). Every bag's
capacity factor is one group (:func:`flexlift.sweep.studies.group_of`).

:func:`indices` estimates S1 and ST of each group for one output (``SALib.analyze.sobol``,
Jansen's and Saltelli's estimators) with bootstrap 95 % confidence half-widths; a base
sample whose rows have any missing output (a run that failed or never arrived) is left out
whole. A group is named a *driver* only when its total index's interval excludes zero
(ST - half-width > 0). The outputs are continuous: each criterion's relative margin to its
limit, 1 - peak / limit (speeds, pitch, the hull's utilisation), and the arrival time.
The rows of this design are not independent draws: no probability is computed from them.
"""

from __future__ import annotations

import warnings

import numpy as np

#: bootstrap resamples of the confidence intervals
RESAMPLES = 200
#: the fewest whole base samples that give indices (fewer: none; a SPEC asking fewer is refused)
MIN_BASE = 8
#: the outputs: (name, headline number or None, what it is)
OUTPUTS = (("margin_ascent_velocity", "max_ascent_velocity_ms"),
           ("margin_descent_velocity", "max_descent_velocity_ms"),
           ("margin_pitch", "max_pitch_deg"),
           ("margin_utilisation", "max_utilisation"),
           ("arrival_time_s", None))


def problem(keys: list[str], groups: dict[str, list[str]]) -> dict:
    """SALib's problem over the unit cube, with the groups."""
    group_of = {k: g for g, ks in groups.items() for k in ks}
    out = {"num_vars": len(keys), "names": list(keys), "bounds": [[0.0, 1.0]] * len(keys)}
    if any(len(ks) > 1 for ks in groups.values()):
        out["groups"] = [group_of[k] for k in keys]
    return out


def saltelli_design(keys: list[str], groups: dict[str, list[str]], n: int, seed: int) -> np.ndarray:
    """(n x (groups + 2), len(keys)) numbers in [0, 1): Saltelli's design of ``n`` base
    samples (a power of 2 keeps the Sobol' sequence balanced)."""
    from SALib.sample import sobol as sample

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # n not a power of 2: SALib's advice, not an error
        u = sample.sample(problem(keys, groups), int(n), calc_second_order=False, scramble=True,
                          seed=int(seed))
    return np.clip(u, 0.0, 1.0 - 1e-16)


def indices(keys: list[str], groups: dict[str, list[str]], y, seed: int) -> dict:
    """{group: {S1, S1_conf, ST, ST_conf, driver}} of the output ``y`` (one value per row of
    the design, NaN where missing), with ``n_used`` base samples; ``None`` for the indices
    when fewer than 8 base samples are whole or the output does not vary."""
    from SALib.analyze import sobol as analyze

    d = len(groups)
    y = np.asarray(y, dtype=float).reshape(-1, d + 2)
    whole = np.all(np.isfinite(y), axis=1)
    y = y[whole]
    out = {"n_used": int(y.shape[0]), "groups": {}}
    if y.shape[0] < MIN_BASE or np.ptp(y) == 0:
        return out
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        si = analyze.analyze(problem(keys, groups), y.ravel(), calc_second_order=False,
                             num_resamples=RESAMPLES, conf_level=0.95, seed=int(seed) + 1)
    names = list(dict.fromkeys(problem(keys, groups).get("groups", keys)))
    for j, g in enumerate(names):
        st, st_c = float(si["ST"][j]), float(si["ST_conf"][j])
        out["groups"][g] = {"S1": float(si["S1"][j]), "S1_conf": float(si["S1_conf"][j]),
                            "ST": st, "ST_conf": st_c, "driver": bool(st - st_c > 0)}
    return out


def outputs(records: dict, mode: str, n_cases: int, limits_for) -> dict[str, np.ndarray]:
    """{output: one value per case of the design (NaN where missing)}; ``limits_for(values)``
    gives a case's {headline number: limit}."""
    out = {name: np.full(n_cases, np.nan) for name, _ in OUTPUTS}
    for i, r in records.items():
        res = r.get("results", {}).get(mode)
        if r["status"] == "lost" or res is None or res.get("status") != "completed":
            continue
        h, lim = res.get("headline", {}), limits_for(r.get("values", {}))
        for name, head in OUTPUTS:
            if head is None:
                v = res.get("arrival_s")
                out[name][i] = np.nan if v is None else float(v)
            elif h.get(head) is not None and lim.get(head):
                out[name][i] = 1.0 - float(h[head]) / lim[head]
    return out


def sobol_summary(spec, records: dict) -> dict:
    """{mode: {output: indices(...)}} of a ``sobol`` sweep."""
    from flexlift.sweep.aggregate import limits_of

    keys, groups = list(spec.distributions), spec.groups
    out = {}
    for mode in spec.controls:
        ys = outputs(records, mode, spec.n_cases, lambda v: limits_of(spec.base, v))
        out[mode] = {name: indices(keys, groups, y, spec.seed) for name, y in ys.items()}
    return out
