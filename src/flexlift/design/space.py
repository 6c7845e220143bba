"""The designer's search space and a candidate's scenario (docs/theory/design.md#space).

A candidate is a few named choices: the catalogue bag (``model``), the number of lift points
(``points``), the bags in all (``bags``: the fewest that lift with the factors,
:mod:`flexlift.design.bound`, plus ``over``), shared over the points as evenly as they go
(the count per point: ``bags // points``, one more at ``bags % points`` points spread along
the hull; or a count per point the user fixes), the control mode, the planned ascent speed,
the breakout pull, the dump valve as a factor on the catalogue bag's, the internal bags
(``internal`` of the ``bags``, in the tanks: :mod:`flexlift.design.internal`), one catalogue
bag per lift point (``point_models``: :mod:`flexlift.design.mixed`) and the compressor's
free-air delivery (``gas.supply_free_air_m3_min``) and, for a staged lift (``control.sequence``),
the staging (``sequence``: ``own``, the scenario's stages, or ``none``, every bag at once;
docs/theory/design.md#staging). Every part is a tuple of allowed values;
a part given one value is fixed by the user. The lift points are placed by the balanced layout's rule
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

from flexlift import constants as C
from flexlift.design import internal as tanks
from flexlift.design import mixed
from flexlift.errors import InputError
from flexlift.loads import balance
from flexlift.scenario import catalogue

#: the variables of a candidate, in the order the optimiser asks for them
VARIABLES = ("model", "points", "internal", "over", "mode", "ascent_speed_m_s",
             "breakout_pull_t", "dump_valve_factor", "supply_free_air_m3_min", "sequence")
#: the largest dump-valve factor on the catalogue bag's valve (--dump-valve)
DUMP_FACTOR_MAX = 100.0
#: the staging choices: the scenario's own ``control.sequence``, or none (every bag at once)
SEQUENCES = ("own", "none")
#: the parts added after the first caches: left out of the key at these values, so that a
#: candidate without them keeps the key it had
NEW_DEFAULTS = {"internal": 0, "point_models": None, "supply_free_air_m3_min": None,
                "sequence": "own"}


@dataclass(frozen=True)
class Candidate:
    """One plan to evaluate: its bag, points and counts (``count`` external bags at every
    point, one more at ``extra`` of them; ``internal`` more in the tanks), its control and
    equipment choices; ``point_models`` each point's own catalogue bag (aft to bow), None:
    ``model`` at every point; ``supply_free_air_m3_min`` None: the scenario's supply;
    ``sequence`` ``own``: the scenario's staging (if any), ``none``: every bag at once."""

    model: str
    points: int
    count: int
    extra: int
    mode: str
    ascent_speed_m_s: float
    breakout_pull_t: float | None
    dump_valve_factor: float
    internal: int = 0
    point_models: tuple[str, ...] | None = None
    supply_free_air_m3_min: float | None = None
    sequence: str = "own"

    @property
    def bags(self) -> int:
        """Bags in all, external and internal."""
        return self.points * self.count + self.extra + self.internal

    def counts(self) -> list[int]:
        """External bags at each point, aft to bow: the ``extra`` bags spread evenly."""
        return mixed.spread(self.points * self.count + self.extra, self.points)

    def models(self) -> list[str]:
        """Each lift point's catalogue bag, aft to bow."""
        return list(self.point_models) if self.point_models else [self.model] * self.points

    def key(self) -> str:
        """The checksum that names this candidate in the cache (its values only; the parts of
        :data:`NEW_DEFAULTS` only when they differ from those values)."""
        d = asdict(self)
        if d["point_models"] is not None:
            d["point_models"] = list(d["point_models"])
        d = {k: v for k, v in d.items() if k not in NEW_DEFAULTS or v != NEW_DEFAULTS[k]}
        text = json.dumps(d, sort_keys=True)
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
    internal: tuple[int, int] = (0, 0)  # inclusive range: internal bags of the bags in all
    per_point: bool = False  # one catalogue bag per lift point
    supplies: tuple[float | None, ...] = (None,)  # free-air deliveries [m^3/min]; None: own
    sequences: tuple[str, ...] = ("own",)  # staging: the scenario's own, or none
    staged: bool = False  # the scenario is a staged lift (control.sequence)
    span_m: tuple[float, float] | None = None
    entries: dict = field(default_factory=dict, compare=False)  # model -> catalogue entry

    def fixed(self) -> dict:
        """The variables with one allowed value, and that value."""
        parts = {"model": self.models, "points": _range(self.points),
                 "over": _range(self.over), "mode": self.modes,
                 "ascent_speed_m_s": self.ascent_speeds, "breakout_pull_t": self.breakout_pulls,
                 "dump_valve_factor": self.dump_valve_factors,
                 "internal": _range(self.internal),
                 "supply_free_air_m3_min": self.supplies, "sequence": self.sequences}
        if self.per_point:
            parts["model"] = ()  # asked point by point
        return {k: v[0] for k, v in parts.items() if len(v) == 1}


def _range(pair) -> tuple:
    return tuple(range(pair[0], pair[1] + 1))


def make_space(scenario, models=None, points=None, over=None, count=None, modes=None,
               speeds=None, pulls=None, dump_factors=None, span=None, internal=None,
               per_point=False, supplies=None, sequences=None) -> Space:
    """The search space of ``scenario``: each part as given (a sequence of allowed values, a
    ``(low, high)`` range for ``points``, ``over`` and ``internal``), else its default
    (every catalogue bag that is not kept as published, 1..12 points (or up to twice the
    user's own plan's lift points, when more: a long line needs its spans short), 0..12 bags
    over the fewest, 0..the most internal bags the tanks hold of the smallest bag offered, the
    scenario's mode, speed, pull and supply, the catalogue's dump valve; a staged lift's
    staging ``own`` or ``none``, an unstaged one's ``own``); ``per_point``: one catalogue bag
    per lift point. An empty or contradictory part is an InputError (one line)."""
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
    if count is not None and over is not None:  # points x count fixes the bags: over is moot
        raise InputError("--over", f"{over[0]}..{over[1]}", f"--count {count} fixes the bags "
                         "(lift points x count): give --count or --over, not both")
    own = len(scenario.lift.bags or [])  # the user's own plan's lift points
    space = Space(models=models, points=_pair(points, (1, max(12, 2 * own)), "--points"),
                  over=_pair(over, (0, 12), "--over", low=0),
                  count=None if count is None else int(count),
                  modes=tuple(modes or (c.mode,)), ascent_speeds=tuple(speeds or
                                                                       (c.ascent_speed_m_s,)),
                  breakout_pulls=tuple(pulls or (c.breakout_pull_t,)),
                  dump_valve_factors=tuple(dump_factors or (1.0,)),
                  span_m=_span(span, scenario.hull.length_m),
                  entries={m: cat[m] for m in models},
                  internal=_internal(scenario, internal, [cat[m] for m in models]),
                  per_point=bool(per_point), supplies=_supplies(supplies),
                  sequences=_sequences(scenario, sequences),
                  staged=scenario.control.sequence is not None)
    if space.per_point:
        mixed.check_one_type(space.entries)
    for name, values in (("--modes", space.modes), ("--speeds", space.ascent_speeds),
                         ("--dump-valve", space.dump_valve_factors)):
        if not values:
            raise InputError(name, "", "give at least one value")
    _check_choices(scenario, space)
    return space


def _check_choices(scenario, space: Space) -> None:
    """Each control choice applied alone to the scenario, so that a value no candidate could
    take (an unknown mode, a speed or pull out of range) is refused here, in one line, not
    found out by every candidate's statics; a dump-valve factor must be positive."""
    for name, key, values in (("--modes", "control.mode", space.modes),
                              ("--speeds", "control.ascent_speed_m_s", space.ascent_speeds),
                              ("--pulls", "control.breakout_pull_t", space.breakout_pulls)):
        for v in values:
            if v is None:
                continue
            try:
                scenario.with_changes(**{key: v})
            except InputError as exc:
                parts = str(exc).split(": ", 2)  # "<source>: <key> = <value>: <allowed>"
                raise InputError(name, v, f"{key}: {parts[-1]}") from None
    for f in space.dump_valve_factors:
        if not (isinstance(f, (int, float)) and 0.0 < f <= DUMP_FACTOR_MAX):
            raise InputError("--dump-valve", f, "a factor on the catalogue bag's dump-valve "
                             f"capacity, 0 < factor <= {DUMP_FACTOR_MAX:g}")
    from flexlift.scenario.valves import purge_given

    if any(f != 1.0 for f in space.dump_valve_factors) and purge_given(scenario):
        # the scenario's own valve replaces every catalogue bag's: a factor would change nothing
        raise InputError("--dump-valve", ",".join(f"{f:g}" for f in space.dump_valve_factors),
                         "the scenario gives gas.purge_rate_max_m3_s, which replaces the "
                         "catalogue bag's dump valve: change that key instead")


def _internal(scenario, value, entries) -> tuple[int, int]:
    """The range of internal bags: as given (refused on a structure without tanks, or above
    what the tanks hold of every bag offered), else 0..the most (:mod:`~flexlift.design.internal`)."""
    from flexlift.structure.hull import hull_from_scenario

    lo, hi = (0, None) if value is None else _pair(value, (0, 0), "--internal", low=0)
    if not tanks.has_tanks(scenario):
        if hi:
            raise InputError("--internal", f"{lo}..{hi}", "the structure has no ballast tanks "
                             "(hull.ballast_tank_frames): 0 internal bags")
        return 0, 0
    hull = hull_from_scenario(scenario)
    most = max(tanks.most_internal(scenario, hull, e) for e in entries)
    if value is None:
        return 0, most
    if lo > most:
        raise InputError("--internal", f"{lo}..{hi}", f"the tanks hold at most {most} of the "
                         "bags offered (docs/theory/design.md#internal-bags)")
    return lo, hi


def _sequences(scenario, values) -> tuple[str, ...]:
    """The staging choices: as given (``own``, ``none``), else both for a staged lift (a
    candidate's layout is not the one the scenario's stages were drawn for: the stages of
    ``group_size`` bags span other lengths of the structure) and ``own`` for an unstaged
    one."""
    staged = scenario.control.sequence is not None
    if values is None:
        return SEQUENCES if staged else ("own",)
    out = tuple(dict.fromkeys(str(v) for v in values))
    for v in out:
        if v not in SEQUENCES:
            raise InputError("--sequence", v, "own (the scenario's control.sequence) or none "
                             "(every bag at once)")
    if not out:
        raise InputError("--sequence", "", "give at least one value: own or none")
    return out


def _supplies(values) -> tuple[float | None, ...]:
    """The compressors' free-air deliveries [m^3/min] (None: the scenario's own supply)."""
    if values is None:
        return (None,)
    out = tuple(None if v is None else float(v) for v in values)
    for v in out:
        if v is not None and not 0.01 <= v <= 100_000:
            raise InputError("--supply", v, "a compressor's free-air delivery in m3/min, "
                             "0.01..100000, or auto (the scenario's supply)")
    if not out:
        raise InputError("--supply", "", "give at least one value")
    return out


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


def positions(hull, scenario, counts: list[int], span: tuple[float, float],
              internal: list[dict] = ()) -> list[float]:
    """The lift points' positions [m] for ``counts`` external bags at each (module
    docstring), balancing what the ``internal`` bags (``lift.bags`` entries, full) leave."""
    env = scenario.environment
    g, rho, rho_s = env.gravity_m_s2, env.seawater_density_kg_m3, env.steel_density_kg_m3
    x, q, pts = balance.design_load(hull, hull.wet_weight_per_length(g, rho, rho_s),
                                    hull.point_wet_weights(g, rho, rho_s),
                                    [tuple(b["span_m"]) for b in internal],
                                    [b["lift_t"] * C.TONNE * g for b in internal], 1.0)
    each = balance.equal_share_positions(x, q, pts, int(sum(counts)))
    out, k = [], 0
    for n in counts:
        out.append(float(np.clip(np.mean(each[k:k + n]), span[0], span[1])))
        k += n
    return out


def catalogue_bag(candidate: Candidate, space: Space, scenario=None) -> dict:
    """``lift.catalogue_bag`` of ``candidate``: its bag's entry (with per-point types the
    envelope of the points' bags, :func:`flexlift.design.mixed.envelope`), its dump valve
    scaled by the candidate's factor."""
    models = sorted(set(candidate.models()))
    entry = (mixed.envelope(models, space.entries) if len(models) > 1
             else space.entries[candidate.model])
    bag = {k: v for k, v in entry.items() if k in ("type", "lift_t", "diameter_m", "length_m",
                                                   "working_pressure_bar", "relief_bar",
                                                   "dump_valve_m3_s", "rated_depth_m",
                                                   "cone_top_m")}
    bag["model"] = candidate.model
    if bag.get("dump_valve_m3_s") is not None:
        bag["dump_valve_m3_s"] = float(bag["dump_valve_m3_s"]) * candidate.dump_valve_factor
    elif candidate.dump_valve_factor != 1.0 and scenario is not None:
        # an entry without a valve (the paper's cylinder) purges through the scenario's
        # gas.purge_rate_max_m3_s: the factor is on that valve, the external bags' own
        bag["dump_valve_m3_s"] = (float(scenario.gas.purge_rate_max_m3_s)
                                  * candidate.dump_valve_factor)
    return bag


def candidate_changes(candidate: Candidate, space: Space, hull, scenario) -> dict:
    """The dotted scenario changes that make ``candidate`` the plan: the catalogue bag, its
    lift points listed in ``lift.bags`` (clusters by ``count``, each of its point's bag's
    lift), its internal bags over the tanks, the control, staging and supply choices."""
    lift_int = float(space.entries[candidate.model]["lift_t"])
    inner = tanks.internal_specs(scenario, hull, candidate.internal, lift_int)
    counts = candidate.counts()
    xs = positions(hull, scenario, counts, space.span_m, inner)
    bags = [{"name": f"p{j + 1}", "kind": "external", "x_m": round(x, 4), "count": n,
             "lift_t": float(space.entries[m]["lift_t"])}
            for j, (x, n, m) in enumerate(zip(xs, counts, candidate.models()))]
    out = {"lift.catalogue_bag": catalogue_bag(candidate, space, scenario),
           "lift.bags": bags + inner,
           "lift.internal_bags": candidate.internal, "lift.bag_lift_t": None,
           "control.mode": candidate.mode,
           "control.ascent_speed_m_s": candidate.ascent_speed_m_s,
           "control.breakout_pull_t": candidate.breakout_pull_t}
    if candidate.supply_free_air_m3_min is not None:
        out["gas.supply_free_air_m3_min"] = candidate.supply_free_air_m3_min
    if candidate.sequence == "none":
        out["control.sequence"] = None  # every bag at once
    if scenario.pipe is not None and scenario.pipe.lift_points is not None:
        out["pipe.lift_points"] = None  # the candidate's lift.bags place the bags, not the pipe's
    return out
