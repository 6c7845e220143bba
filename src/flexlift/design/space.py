"""The designer's search space and a candidate's scenario (docs/theory/design.md#space).

A candidate is a few named choices: the catalogue bag (``model``), the number of lift points
(``points``), the bags in all (``bags``: the fewest that lift with the factors,
:mod:`flexlift.design.bound`, plus ``over``), shared over the points as evenly as they go
(the count per point: ``bags // points``, one more at ``bags % points`` points spread along
the hull; or a count per point the user fixes), the control mode, the planned ascent speed,
the breakout pull, and the dump valve as a factor on the catalogue bag's. Every part is a tuple of allowed values; a part given one value is fixed
by the user. The lift points are placed by the balanced layout's rule
(:func:`flexlift.loads.balance.equal_share_positions`): the n bags' equal-load centroids,
grouped in order into the points by their counts, each point at its group's mean, so the
lift centroid stays on the centre of what the bags carry whatever the counts; points are
kept inside the hull's allowed attachment span.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field

import numpy as np

from flexlift.errors import InputError
from flexlift.loads import balance
from flexlift.scenario import catalogue

#: the variables of a candidate, in the order the optimiser asks for them
VARIABLES = ("model", "points", "over", "mode", "ascent_speed_m_s",
             "breakout_pull_t", "dump_valve_factor")


@dataclass(frozen=True)
class Candidate:
    """One plan to evaluate: its bag, points and counts (``count`` at every point, one more
    at ``extra`` of them), its control choices."""

    model: str
    points: int
    count: int
    extra: int
    mode: str
    ascent_speed_m_s: float
    breakout_pull_t: float | None
    dump_valve_factor: float

    @property
    def bags(self) -> int:
        return self.points * self.count + self.extra

    def counts(self) -> list[int]:
        """Bags at each point, aft to bow: the ``extra`` bags spread evenly over the points."""
        out = [self.count] * self.points
        for j in range(self.extra):
            out[int((j + 0.5) * self.points / self.extra)] += 1
        return out

    def key(self) -> str:
        """The checksum that names this candidate in the cache (its values only)."""
        text = json.dumps(asdict(self), sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:20]


@dataclass(frozen=True)
class Space:
    """The allowed values of each variable (one value: fixed) and the attachment span [m]."""

    models: tuple[str, ...]
    points: tuple[int, int]  # inclusive range
    over: tuple[int, int]  # inclusive range: bags above the fewest that lift (N)
    count: int | None  # bags per point, when the user fixes it
    modes: tuple[str, ...]
    ascent_speeds: tuple[float, ...]
    breakout_pulls: tuple[float | None, ...]
    dump_valve_factors: tuple[float, ...] = (1.0,)
    span_m: tuple[float, float] | None = None
    entries: dict = field(default_factory=dict, compare=False)  # model -> catalogue entry

    def fixed(self) -> dict:
        """The variables with one allowed value, and that value."""
        parts = {"model": self.models, "points": _range(self.points),
                 "over": _range(self.over), "mode": self.modes,
                 "ascent_speed_m_s": self.ascent_speeds, "breakout_pull_t": self.breakout_pulls,
                 "dump_valve_factor": self.dump_valve_factors}
        return {k: v[0] for k, v in parts.items() if len(v) == 1}


def _range(pair) -> tuple:
    return tuple(range(pair[0], pair[1] + 1))


def make_space(scenario, models=None, points=None, over=None, count=None, modes=None,
               speeds=None, pulls=None, dump_factors=None, span=None) -> Space:
    """The search space of ``scenario``: each part as given (a sequence of allowed values, a
    ``(low, high)`` range for ``points`` and ``over``), else its default (every catalogue
    bag that is not kept as published, 1..12 points, 0..12 bags over the fewest, the
    scenario's mode, speed and pull, the catalogue's dump valve). An empty or contradictory
    part is an InputError (one line)."""
    cat = catalogue.load(scenario.lift.catalogue_file)
    if models is None:
        models = tuple(n for n, e in cat.items() if not e.get("as_published"))
    models = tuple(models)
    if not models:
        raise InputError("--bags", "", "the catalogue offers no bag to design with; name at "
                         "least one catalogue bag")
    for m in models:
        if m not in cat:
            catalogue.resolve(m, scenario.lift.catalogue_file)  # one line with the near names
    c = scenario.control
    if count is not None and not 1 <= int(count):
        raise InputError("--count", count, "a whole number of bags per point, at least 1")
    space = Space(models=models, points=_pair(points, (1, 12), "--points"),
                  over=_pair(over, (0, 12), "--over", low=0),
                  count=None if count is None else int(count),
                  modes=tuple(modes or (c.mode,)), ascent_speeds=tuple(speeds or
                                                                       (c.ascent_speed_m_s,)),
                  breakout_pulls=tuple(pulls or (c.breakout_pull_t,)),
                  dump_valve_factors=tuple(dump_factors or (1.0,)),
                  span_m=_span(span, scenario.hull.length_m),
                  entries={m: cat[m] for m in models})
    for name, values in (("--modes", space.modes), ("--speeds", space.ascent_speeds),
                         ("--dump-valve", space.dump_valve_factors)):
        if not values:
            raise InputError(name, "", "give at least one value")
    return space


def _pair(value, default, name, low: int = 1) -> tuple[int, int]:
    lo, hi = default if value is None else value
    if not low <= lo <= hi:
        raise InputError(name, f"{lo}..{hi}", f"a range low..high of whole numbers, {low} <= "
                         "low <= high")
    return int(lo), int(hi)


def _span(span, length: float) -> tuple[float, float]:
    if span is None:
        return 0.0, float(length)
    a, b = (float(v) for v in span)
    if not 0 <= a < b <= length:
        raise InputError("--span", f"{a:g}..{b:g}", f"the attachment span must lie on the "
                         f"hull, 0 <= from < to <= {length:g} m")
    return a, b


def positions(hull, scenario, counts: list[int], span: tuple[float, float]) -> list[float]:
    """The lift points' positions [m] for ``counts`` bags at each (module docstring)."""
    env = scenario.environment
    g, rho, rho_s = env.gravity_m_s2, env.seawater_density_kg_m3, env.steel_density_kg_m3
    x, q, pts = balance.design_load(hull, hull.wet_weight_per_length(g, rho, rho_s),
                                    hull.point_wet_weights(g, rho, rho_s), [], [], 1.0)
    each = balance.equal_share_positions(x, q, pts, int(sum(counts)))
    out, k = [], 0
    for n in counts:
        out.append(float(np.clip(np.mean(each[k:k + n]), span[0], span[1])))
        k += n
    return out


def candidate_changes(candidate: Candidate, space: Space, hull, scenario) -> dict:
    """The dotted scenario changes that make ``candidate`` the plan: the catalogue bag, its
    lift points listed in ``lift.bags`` (clusters by ``count``), the control choices."""
    entry = space.entries[candidate.model]
    bag = {k: v for k, v in entry.items() if k in ("type", "lift_t", "diameter_m", "length_m",
                                                   "working_pressure_bar", "relief_bar",
                                                   "dump_valve_m3_s", "rated_depth_m",
                                                   "cone_top_m")}
    bag["model"] = candidate.model
    if bag.get("dump_valve_m3_s") is not None:
        bag["dump_valve_m3_s"] = float(bag["dump_valve_m3_s"]) * candidate.dump_valve_factor
    counts = candidate.counts()
    xs = positions(hull, scenario, counts, space.span_m)
    bags = [{"name": f"p{j + 1}", "kind": "external", "x_m": round(x, 4), "count": n,
             "lift_t": float(entry["lift_t"])} for j, (x, n) in enumerate(zip(xs, counts))]
    return {"lift.catalogue_bag": bag, "lift.bags": bags, "lift.internal_bags": 0,
            "lift.bag_lift_t": None, "control.mode": candidate.mode,
            "control.ascent_speed_m_s": candidate.ascent_speed_m_s,
            "control.breakout_pull_t": candidate.breakout_pull_t}
