"""An ascent's per-bag numbers as tables that read the same for 7 bags and for 400: one row per
lift point on the page (:mod:`flexlift.output.liftpoints`), one row per bag in the CSV, and
the events of a lift point's bags merged into one row."""

from __future__ import annotations

import numpy as np

from flexlift.output.liftpoints import lift_points
from flexlift.output.stage import Table


def _num(v) -> float | None:
    v = float(v)
    return v if np.isfinite(v) else None


def _range(values) -> str | float | None:
    """One value, or "lo..hi" when the bags differ [same unit]."""
    v = np.asarray(values, dtype=float)
    if not np.isfinite(v).all():
        return "not every bag" if np.isfinite(v).any() else None
    lo, hi = float(v.min()), float(v.max())
    return round(lo, 1) if hi - lo < 0.05 else f"{lo:.1f}..{hi:.1f}"


def point_tables(result, mode: str) -> tuple[Table, Table]:
    """(the lift points: where, how many bags, arrival, final height and gas, on the page;
    every bag: the same per bag, CSV only ``simulate_<mode>_bags.csv``)."""
    ds = result.dataset
    points = lift_points(ds)
    arrival = ds.arrival_time.values
    final = ds.height.values[-1] if ds.time.size else np.full(ds.bag.size, np.nan)
    gas0, used = ds.gas_initial_free_air.values, ds.gas_used_free_air.values
    vented, purged = ds.gas_vented_free_air.values, ds.gas_purged_free_air.values
    rows = []
    for p in points:
        i = p.index
        rows.append([p.label, p.kind, round(p.x, 2), p.count, _range(arrival[i]),
                     _range(final[i]), float(np.sum(gas0[i] + used[i])),
                     float(np.sum(vented[i] + purged[i]))])
    per_point = Table(
        f"Lift points ({mode}): {len(points)} point(s), {ds.bag.size} bag(s)",
        ["lift point (bags)", "kind", "x [m]", "bags", "arrival [s]", "final height [m]",
         "gas in all, free air [m3]", "gas vented and purged, free air [m3]"], rows,
        note="A range a..b where the point's bags differ; every bag's numbers in the CSV.",
        csv=f"simulate_{mode}_lift_points.csv")
    where = {b: p.label for p in points for b in p.bags}
    bag_rows = [[str(b), where[str(b)], str(ds.bag_kind.values[k]), float(ds.bag_x.values[k]),
                 _num(arrival[k]), _num(final[k]), float(gas0[k]), float(used[k]),
                 float(vented[k]), float(purged[k])] for k, b in enumerate(ds.bag.values)]
    per_bag = Table(
        f"Every bag ({mode})",
        ["bag", "lift point", "kind", "x [m]", "arrival [s]", "final height [m]",
         "initial fill, free air [m3]", "top-up, free air [m3]", "vented, free air [m3]",
         "purged, free air [m3]"], bag_rows, csv=f"simulate_{mode}_bags.csv", in_report=False)
    return per_point, per_bag


def event_rows(result) -> list[list]:
    """The events as table rows (time [s], kind, bag, detail), those of one kind on the bags
    of one lift point merged into one row at the first of them ("8 bags, the last at 3446.0 s");
    an event of one bag alone (a fault on it) names that bag. Rows in time order, those at
    the same time the structure's first, then aft to bow by their lift points (ten points
    arriving in the same step read in order along the hull)."""
    points = lift_points(result.dataset)
    point_of = {b: p for p in points for b in p.bags}
    merged: dict[tuple, list[dict]] = {}
    keyed = []  # ((time, x of the lift point, -inf for the structure's), row)
    for e in result.events:
        p = point_of.get(e["bag"]) if e["bag"] else None
        if p is None or p.count == 1:
            x = p.x if p is not None else -np.inf
            keyed.append(((e["time_s"], x), [e["time_s"], e["kind"], e["bag"] or "",
                                             e.get("detail", "")]))
            continue
        merged.setdefault((e["kind"], p.label, e.get("detail", "")), []).append(e)
    for (kind, label, detail), es in merged.items():
        times = [e["time_s"] for e in es]
        names = {e["bag"] for e in es}
        x = point_of[es[0]["bag"]].x
        if len(es) == 1:  # one bag of the point (a fault on it): that bag, as it is
            e = es[0]
            keyed.append(((e["time_s"], x), [e["time_s"], kind, e["bag"], detail]))
            continue
        n = len(names)
        count = f"{n} bag{'s' if n > 1 else ''}, {len(es)} events" if n < len(es) else f"{n} bags"
        more = f"{count}, the last at {max(times):.1f} s"
        name = next(iter(names)) if n == 1 else label  # one bag's events: that bag
        keyed.append(((min(times), x), [min(times), kind, name,
                                        f"{detail}; {more}" if detail else more]))
    keyed.sort(key=lambda kr: kr[0])
    return [row for _, row in keyed]
