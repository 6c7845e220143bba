"""What a sweep's cases add up to: failure probabilities, influences, the dataset, the worst.

- **Outcomes** of each case and mode (:mod:`flexlift.ascent.outcome`): safe, unsafe (a limit
  broken), not achieved (every limit held, the plan cannot finish), incomplete (every limit
  held, the run ended first) or failed (numerics, an invalid combination of values, out of
  memory: whether the lift was safe is not known). Each one's probability with its 95 %
  Wilson score interval.
- **Failure probability** of each criterion per control mode (failed cases / cases run, with
  the Wilson interval), and of ``all_criteria``: the union of the criteria, a case failing
  any one of them. Each entry gives ``n`` (the cases it is taken over), ``incomplete`` (how
  many of them ran out of time with every limit held) and ``incomplete_as`` (how those count
  for it): an incomplete case did not hold the target, so it fails ``reached_target`` and
  ``all_criteria`` and passes the limits it held. A mode whose numerics failed counts as
  failing every criterion; a lost case (its worker died twice) counts in none.
- **Influence** of each varied key: Spearman's rank correlation between the key's values and
  a criterion's failure (1 failed, 0 passed), or a headline number, over the cases run;
  ranked by its magnitude. Keys whose values do not vary, and criteria whose outcome does not
  vary, have no ranking. Keys holding names (a choice of ``lift.layout``) rank in the order
  of their values' first appearance.
- **Dataset**: a ``case`` dimension (and ``control``) with the varied keys as coordinates.
"""

from __future__ import annotations

import json
import math

import numpy as np

#: z of a two-sided 95 % interval
Z95 = 1.959963984540054
ALL = "all_criteria"
#: the outcomes of a mode's run, worst first, and those a failure probability counts
OUTCOMES = ("unsafe", "not_achieved", "failed", "incomplete", "safe")
FAILING = ("unsafe", "not_achieved", "failed")
#: units of the headline numbers, by the end of their names
UNITS = (("_ms", "m/s"), ("_deg", "deg"), ("_MNm", "MN m"), ("_MN", "MN"), ("_MPa", "MPa"),
         ("_m3", "m3"), ("_hours", "h"), ("_s", "s"))
#: the headline numbers with a limit, and the scenario key of that limit (1: utilisation)
LIMITED = {"max_ascent_velocity_ms": "limits.ascent_velocity_m_s",
           "max_descent_velocity_ms": "limits.descent_velocity_m_s",
           "max_pitch_deg": "limits.pitch_deg", "max_utilisation": None}


def limits_of(base, values: dict | None = None) -> dict:
    """{headline number: its limit} for the base scenario, or for a case of it whose varied
    ``values`` may include limits (``limits.pitch_deg``, ...)."""
    values = values or {}
    out = {}
    for name, key in LIMITED.items():
        if key is None:
            out[name] = 1.0
        elif key in values:
            out[name] = float(values[key])
        elif getattr(base.limits, key.split(".", 1)[1]) is not None:  # null: no criterion
            out[name] = float(getattr(base.limits, key.split(".", 1)[1]))
    return out


def wilson(failed: int, n: int, z: float = Z95) -> dict:
    """The failure probability ``failed / n`` and its Wilson score interval."""
    if n <= 0:
        return {"p": None, "low": None, "high": None, "failed": failed, "n": n}
    p = failed / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z / denom * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    low = 0.0 if failed == 0 else max(0.0, centre - half)
    high = 1.0 if failed == n else min(1.0, centre + half)
    return {"p": p, "low": low, "high": high, "failed": failed, "n": n}


def spearman(x, y) -> float | None:
    """Spearman's rank correlation (average ranks for ties); None when either is constant."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if x.size < 3 or np.ptp(x) == 0 or np.ptp(y) == 0:
        return None
    rx, ry = rankdata(x), rankdata(y)
    rx, ry = rx - rx.mean(), ry - ry.mean()
    return float(np.dot(rx, ry) / math.sqrt(np.dot(rx, rx) * np.dot(ry, ry)))


def rankdata(a) -> np.ndarray:
    """Ranks 1..n, ties given their average rank (``scipy.stats.rankdata``'s default, here
    without importing ``scipy.stats``)."""
    a = np.asarray(a, dtype=float)
    order = np.argsort(a, kind="mergesort")
    sorted_a = a[order]
    first = np.r_[True, sorted_a[1:] != sorted_a[:-1]]
    group = np.cumsum(first) - 1
    starts = np.flatnonzero(first)
    ends = np.r_[starts[1:], a.size]
    mean_rank = (starts + ends + 1) / 2.0  # the average of ranks start+1 .. end
    out = np.empty(a.size)
    out[order] = mean_rank[group]
    return out


# --------------------------------------------------------------------------- outcomes
def ran(records: dict, mode: str) -> list[dict]:
    """The records whose case ran this mode (completed or failed, not lost), by case."""
    return [records[i] for i in sorted(records)
            if records[i]["status"] != "lost" and mode in records[i].get("results", {})]


def criteria_names(records: dict, mode: str) -> list[str]:
    """Every criterion any completed case reported, in order of first appearance."""
    names: dict[str, None] = {}
    for r in ran(records, mode):
        names.update(dict.fromkeys(r["results"][mode].get("criteria", {})))
    return list(names)


def failed_criteria(result: dict, names: list[str]) -> list[str]:
    """The criteria a mode's result failed (all of them when its numerics failed)."""
    if result["status"] != "completed":
        return list(names)
    return [c for c in names if not result["criteria"].get(c, False)]


def outcome_of(result: dict) -> str:
    """A mode's outcome (one of :data:`OUTCOMES`); for a record written before outcomes were
    kept (a resumed sweep), from its criteria: a limit failed is unsafe, only the target not
    reached is not achieved (whether it was merely too short is not known)."""
    if result["status"] != "completed":
        return "failed"
    kind = result.get("outcome")
    if kind in OUTCOMES:
        return kind
    crit = result.get("criteria", {})
    if any(not ok for k, ok in crit.items() if k != "reached_target"):
        return "unsafe"
    return "safe" if crit.get("reached_target", True) else "not_achieved"


def failing(result: dict) -> bool:
    """Whether a mode's run counts as a failure of the lift (:data:`FAILING`)."""
    return outcome_of(result) in FAILING


def any_failed(result: dict, names: list[str]) -> bool:
    """Whether a mode's result failed any criterion of ``names`` (``all_criteria``)."""
    return bool(failed_criteria(result, names)) or (
        result["status"] == "completed" and outcome_of(result) != "safe")


def failure_probability(records: dict, modes) -> dict:
    """{mode: {criterion: wilson(...)}}, with ``all_criteria`` (any criterion failed) last;
    each entry also says how many of its ``n`` cases were incomplete and how they count."""
    out = {}
    for mode in modes:
        rs, names = ran(records, mode), criteria_names(records, mode)
        fails = [failed_criteria(r["results"][mode], names) for r in rs]
        short = [outcome_of(r["results"][mode]) == "incomplete" for r in rs]
        n_short = sum(short)
        out[mode] = {}
        for c in names:
            as_failed = c == "reached_target" or any(
                c in f for f, s in zip(fails, short, strict=True) if s)
            out[mode][c] = {**wilson(sum(c in f for f in fails), len(rs)), "incomplete": n_short,
                            "incomplete_as": "failed" if as_failed else "passed"}
        out[mode][ALL] = {**wilson(sum(any_failed(r["results"][mode], names) for r in rs),
                                   len(rs)),
                          "incomplete": n_short, "incomplete_as": "failed"}
    return out


def outcome_probability(records: dict, modes) -> dict:
    """{mode: {outcome: wilson(...)}} for every outcome but safe, worst first."""
    out = {}
    for mode in modes:
        kinds = [outcome_of(r["results"][mode]) for r in ran(records, mode)]
        out[mode] = {k: wilson(kinds.count(k), len(kinds)) for k in OUTCOMES if k != "safe"}
    return out


def numeric(values: list) -> np.ndarray:
    """Values of a key as numbers for ranking (names in order of first appearance)."""
    if all(isinstance(v, int | float) and not isinstance(v, bool) for v in values):
        return np.asarray(values, dtype=float)
    codes: dict[str, int] = {}
    return np.asarray([codes.setdefault(json.dumps(v, sort_keys=True), len(codes))
                       for v in values], dtype=float)


def _ranked(scores: dict) -> list[list]:
    items = [(k, s) for k, s in scores.items() if s is not None]
    return [[k, round(s, 4)] for k, s in sorted(items, key=lambda kv: -abs(kv[1]))]


def sensitivity(records: dict, modes, keys) -> dict:
    """{mode: {criterion: [[key, rank correlation with failing], ...]}}, strongest first."""
    out = {}
    for mode in modes:
        rs, names = ran(records, mode), criteria_names(records, mode)
        fails = [failed_criteria(r["results"][mode], names) for r in rs]
        xs = {k: numeric([r["values"][k] for r in rs]) for k in keys}
        out[mode] = {}
        bad = [any_failed(r["results"][mode], names) for r in rs]
        for c in [*names, ALL]:
            y = [float(b) for b in bad] if c == ALL else [float(c in f) for f in fails]
            out[mode][c] = _ranked({k: spearman(x, y) for k, x in xs.items()})
    return out


def headline_names(records: dict, mode: str) -> list[str]:
    """The headline numbers of the cases run in this mode (entries that are not numbers,
    such as which bag a peak belongs to, are not aggregated)."""
    names: dict[str, None] = {}
    text: set[str] = set()
    for r in ran(records, mode):
        for k, v in r["results"][mode].get("headline", {}).items():
            names[k] = None
            if not (v is None or isinstance(v, int | float) and not isinstance(v, bool)):
                text.add(k)
    return [k for k in names if k not in text]


def headline_array(records: dict, mode: str, name: str) -> np.ndarray:
    """A headline number of every case run in this mode (NaN where it has none)."""
    vals = [r["results"][mode].get("headline", {}).get(name) for r in ran(records, mode)]
    return np.array([np.nan if v is None else float(v) for v in vals])


def headline_sensitivity(records: dict, modes, keys) -> dict:
    """{mode: {headline number: [[key, rank correlation], ...]}} over the completed cases."""
    out = {}
    for mode in modes:
        rs = ran(records, mode)
        ok = np.array([r["results"][mode]["status"] == "completed" for r in rs], dtype=bool)
        out[mode] = {}
        for name in headline_names(records, mode):
            y = headline_array(records, mode, name)
            good = ok & np.isfinite(y)
            scores = {k: spearman(numeric([r["values"][k] for r in rs])[good], y[good])
                      for k in keys}
            out[mode][name] = _ranked(scores)
    return out


def severity(result: dict, names: list[str], limits: dict) -> tuple:
    """Sort key of a worst case (larger is worse): numerics failed, a failing outcome, criteria
    failed, then
    how close the speeds, the pitch and the hull stress came to their ``limits``
    ({headline number: limit}; the nearest counts)."""
    h = result.get("headline", {})
    margin = max([(h.get(k) or 0.0) / lim for k, lim in limits.items() if lim] or [0.0])
    return (result["status"] != "completed", failing(result), len(failed_criteria(result, names)),
            margin)


def worst_cases(records: dict, mode: str, n: int, base) -> list[int]:
    """The indices of the ``n`` worst cases run in ``mode`` (worst first), each against its own
    limits (those of ``base``, the base scenario, unless the case varies them)."""
    names = criteria_names(records, mode)
    rs = ran(records, mode)
    rs.sort(key=lambda r: severity(r["results"][mode], names, limits_of(base, r["values"])),
            reverse=True)
    return [r["case"] for r in rs[:n]]


# --------------------------------------------------------------------------- the dataset
def _unit(name: str) -> str:
    return next((u for end, u in UNITS if name.endswith(end)), "1")


def _events_text(events: list[dict]) -> str:
    return "; ".join(f"{e['kind']} {e['time_s']:g} s" + (f" ({e['bag']})" if e.get("bag") else "")
                     for e in events)


def build_dataset(spec, cases, names: dict, records: dict, attrs: dict):
    """The sweep as one dataset: ``case`` x ``control``, the varied keys as coordinates."""
    modes, n = list(spec.controls), len(cases)
    coords = {"case": ("case", np.arange(n), {"long_name": "case index"}),
              "control": ("control", np.array(modes, dtype=object)),
              "case_name": ("case", np.array([names[c.index] for c in cases], dtype=object))}
    for k in spec.keys:
        vals = [c.values[k] for c in cases]
        arr = (np.asarray(vals, dtype=float) if all(isinstance(v, int | float) and not
               isinstance(v, bool) for v in vals) else
               np.array([json.dumps(v) if not isinstance(v, str) else v for v in vals], dtype=object))
        coords[k] = ("case", arr, {"long_name": f"swept scenario key {k}"})
    if any(c.seed is not None for c in cases):
        coords["noise_seed"] = ("case", np.array([str(c.seed) for c in cases], dtype=object),
                                {"long_name": "the case's disturbance.seed"})
    recs = [records.get(c.index) for c in cases]
    data = {"status": ("case", np.array([r["status"] if r else "missing" for r in recs], dtype=object),
                       {"long_name": "completed, failed (numerics or an invalid combination) or lost"}),
            "attempts": ("case", np.array([r.get("attempts", 0) if r else 0 for r in recs], dtype=np.int32)),
            "elapsed_s": ("case", np.array([np.nan if not r or r.get("elapsed_s") is None else r["elapsed_s"]
                                            for r in recs]), {"units": "s"})}
    by_mode = {m: criteria_names(records, m) for m in modes}  # once: each reads every record
    crit = list(dict.fromkeys(c for m in modes for c in by_mode[m]))
    head = list(dict.fromkeys(h for m in modes for h in headline_names(records, m)))
    shape = (n, len(modes))
    text = {v: np.full(shape, "", dtype=object) for v in ("mode_status", "outcome", "cause", "error",
                                                          "events", "failed_criteria")}
    flags = {c: np.full(shape, -1, dtype=np.int8) for c in [*crit, ALL]}
    nums = {h: np.full(shape, np.nan) for h in head}
    for i, r in enumerate(recs):
        for j, m in enumerate(modes):
            res = (r or {}).get("results", {}).get(m)
            if res is None or r["status"] == "lost":
                text["mode_status"][i, j] = r["status"] if r else "missing"
                continue
            names_m = by_mode[m]
            failed = failed_criteria(res, names_m)
            text["mode_status"][i, j] = res["status"]
            text["outcome"][i, j] = outcome_of(res)
            text["cause"][i, j] = res.get("cause") or ""
            text["error"][i, j] = res.get("error") or ""
            text["events"][i, j] = _events_text(res.get("events", []))
            text["failed_criteria"][i, j] = ", ".join(failed)
            for c in names_m:
                flags[c][i, j] = 0 if c in failed else 1
            flags[ALL][i, j] = 0 if any_failed(res, names_m) else 1
            for h, v in res.get("headline", {}).items():
                if v is not None and h in nums:
                    nums[h][i, j] = float(v)
    for v, arr in text.items():
        data[v] = (("case", "control"), arr)
    flag_attrs = {"flag_values": np.array([-1, 0, 1], dtype=np.int8),
                  "flag_meanings": "not_run failed passed"}
    for c, arr in flags.items():
        long = ("any criterion failed: unsafe, not achieved, incomplete or failed to run (0); "
                "safe (1)"
                if c == ALL else f"criterion {c}")
        data[f"criterion_{c}"] = (("case", "control"), arr, {**flag_attrs, "long_name": long})
    for h, arr in nums.items():
        data[h] = (("case", "control"), arr, {"units": _unit(h), "long_name": f"headline {h}"})
    import xarray as xr  # here: the coordinator imports it while the cases run

    return xr.Dataset(data, coords=coords, attrs=attrs)


# --------------------------------------------------------------------------- convergence
#: most points of a convergence curve
CONVERGENCE_POINTS = 40


def convergence(records: dict, modes) -> dict:
    """{mode: {"n": [cases], outcome: [[p, low, high], ...]}}: each probability (the outcomes
    but safe, and any criterion failing) after the first n cases run (by case index), at up to
    :data:`CONVERGENCE_POINTS` values of n spaced geometrically, the last all of them."""
    out = {}
    for mode in modes:
        kinds = [outcome_of(r["results"][mode]) for r in ran(records, mode)]
        total = len(kinds)
        if not total:
            out[mode] = {"n": []}
            continue
        ns = sorted({int(round(v)) for v in np.geomspace(1, total, CONVERGENCE_POINTS)} | {total})
        curve: dict = {"n": ns}
        for k in [*(o for o in OUTCOMES if o != "safe"), ALL]:
            hits = np.cumsum([(kind != "safe") if k == ALL else (kind == k) for kind in kinds])
            curve[k] = [[w["p"], w["low"], w["high"]]
                        for w in (wilson(int(hits[n - 1]), n) for n in ns)]
        out[mode] = curve
    return out
