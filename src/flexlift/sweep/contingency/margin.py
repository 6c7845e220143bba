"""The margin of a failing single-failure case: by how much the plan must grow to survive it.

The scale is uniform: on the surviving bags' true gas capacity (the plan pinned in
``lift.bags``, one entry per bag, and every bag but the failed one given its ``capacity_factor``
times the scale: :func:`scale_changes`; a pipeline's bags come from ``pipe:``, so there every
bag's factor, ``lift.catalogue_bag.capacity_factor``, is scaled, the failed one's too) or, for
a dump valve stuck closed, on the external bags' dump valve as the run takes it
(:func:`flexlift.scenario.valves.external_valve`: ``gas.purge_rate_max_m3_s`` or the catalogue
bag's ``dump_valve_m3_s``). The case is run first at
the cap (:data:`CAP`): if it still fails the margin is "> cap"; else the smallest surviving
scale is bisected between 1 and the cap, to 1 % of the scale or 1 t of the plan's capacity
(whichever comes first), in at most :data:`MAX_RUNS` runs in all. The margin is the smallest
scale that survived (an upper bound, the bracket beside it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

#: the largest scale tried, by what is scaled: +30 % (a published incident's bag held 25 %
#: over its rating); one run at the cap and five halvings of [1, 1.3] bracket the margin to
#: 0.3 / 32 < 1 % within the six runs
CAP = {"capacity": 1.3, "dump_valve": 1.3}
#: the most extra runs per failing case
MAX_RUNS = 6
#: the bisection stops within this fraction of the scale
REL_TOL = 0.01


def scaled(kind: str) -> str:
    """What the margin of a failure ``kind`` scales: ``capacity`` or ``dump_valve``."""
    return "dump_valve" if kind == "dump_valve_stuck_closed" else "capacity"


def scale_changes(what: str, scale: float, scenario, failed: str | None = None,
                  pinned: tuple | None = None) -> dict:
    """The dotted changes that scale ``what`` by ``scale`` in ``scenario``: the dump valves'
    capacity; or, with the plan ``pinned`` (:func:`pinned_bags`), the true capacity of every
    bag but ``failed`` (the survivors); without it (a pipeline) every bag's."""
    if what == "dump_valve":
        from flexlift.scenario.valves import external_valve

        valve = external_valve(scenario)  # the valve the run uses, by the key that sets it
        return {valve.key: valve.m3_s * scale}
    default = scenario.lift.catalogue_bag.capacity_factor
    if pinned is None:
        return {"lift.catalogue_bag.capacity_factor": default * scale}
    bags = []
    for b in pinned:
        b = dict(b)
        if b["name"] != failed:
            b["capacity_factor"] = b.get("capacity_factor", default) * scale
        bags.append(b)
    return {"lift.bags": bags}


def pinned_bags(scenario) -> tuple | None:
    """The plan of ``scenario`` as ``lift.bags`` entries, one per bag (None for a pipeline,
    whose bags come from ``pipe:``)."""
    if scenario.pipe is not None:
        return None
    from flexlift.sweep.studies import pin_plan

    pinned = pin_plan(scenario, "contingency")[0]
    return tuple(b.model_dump(mode="json", exclude_none=True) for b in pinned.lift.bags)


@dataclass
class Bisection:
    """The search for the smallest surviving scale in (1, ``cap``] of one failing case.

    ``unit_t``: the plan's capacity per unit of scale [t] (the 1 t tolerance; 0: none).
    Ask :meth:`next_scale` (None when done), run the case at it, :meth:`tell` the result."""

    cap: float
    unit_t: float = 0.0
    low: float = 1.0  # fails
    high: float | None = None  # survives (None: not yet found)
    runs: list = field(default_factory=list)  # (scale, survived)

    def next_scale(self) -> float | None:
        if len(self.runs) >= MAX_RUNS:
            return None
        if not self.runs:
            return self.cap
        if self.high is None:  # failed at the cap
            return None
        width = self.high - self.low
        if width <= REL_TOL * self.high or (self.unit_t > 0 and width * self.unit_t <= 1.0):
            return None
        return round(0.5 * (self.low + self.high), 6)

    def tell(self, scale: float, survived: bool) -> None:
        self.runs.append((scale, bool(survived)))
        if survived:
            self.high = scale if self.high is None else min(self.high, scale)
        else:
            self.low = max(self.low, scale)

    def result(self) -> dict:
        """``{"scale": smallest surviving scale or None, "text": "x1.23" or "> x1.3",
        "bracket": [low, high], "runs": n}``."""
        if self.high is None:
            return {"scale": None, "text": f"> x{self.cap:g}", "bracket": [self.low, None],
                    "runs": len(self.runs)}
        return {"scale": self.high, "text": f"x{self.high:.3g}",
                "bracket": [round(self.low, 6), round(self.high, 6)], "runs": len(self.runs)}


def bisect_margin(survives, cap: float, unit_t: float = 0.0) -> dict:
    """The margin of one case run in sequence: ``survives(scale)`` -> bool (one run each)."""
    b = Bisection(cap, unit_t)
    while (s := b.next_scale()) is not None:
        b.tell(s, survives(s))
    return b.result()
