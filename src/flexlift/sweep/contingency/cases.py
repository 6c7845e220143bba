"""The cases of a single-failure study: every applicable (bag, kind, phase) of a plan.

A kind applies to a bag that has the part that fails (SPEC §10.4): every bag can be lost
(``bag_rupture``: its gas gone within :data:`LEAK_TIME_S`); an external (parachute) bag also
hangs on a sling and has its own fill and dump valves, supply line and sensors; the internal
cylinders (the paper's) have none of these of their own, so only their loss applies.

Identical bags at one lift point under the same control give the same result only without
noise: then one representative per lift point and type is run (the first bag of its group,
its members listed with it); with noise (force or measurement), or with ``all_bags``, every
bag is run.
"""

from __future__ import annotations

from dataclasses import dataclass

from flexlift.errors import InputError

#: the kinds of a single failure, as the scenario's fault kinds, in the report's order
KINDS = ("bag_rupture", "sling_break", "dump_valve_stuck_closed", "fill_valve_stuck_open",
         "fill_valve_stuck_closed", "supply_failure", "sensor_stuck", "sensor_drift",
         "sensor_dropout")
#: what each kind is, in the report's words
KIND_TEXT = {"bag_rupture": "bag lost", "sling_break": "sling broken",
             "dump_valve_stuck_closed": "dump valve stuck closed",
             "fill_valve_stuck_open": "fill valve stuck open",
             "fill_valve_stuck_closed": "fill valve stuck closed", "supply_failure": "supply lost",
             "sensor_stuck": "sensor stuck", "sensor_drift": "sensor drifting",
             "sensor_dropout": "sensor dropped out"}
#: the part each kind needs
PART = {"bag_rupture": "bag", "sling_break": "sling", "dump_valve_stuck_closed": "dump valve",
        "fill_valve_stuck_open": "fill valve", "fill_valve_stuck_closed": "fill valve",
        "supply_failure": "gas supply",
        "sensor_stuck": "sensors", "sensor_drift": "sensors", "sensor_dropout": "sensors"}
#: a lost bag's gas escapes with this time constant [s] (the fault's default)
LEAK_TIME_S = 5.0


@dataclass(frozen=True)
class Group:
    """Identical bags at one lift point: ``members`` (names), ``external``, ``x_m`` [m]."""

    members: tuple[str, ...]
    external: bool
    x_m: float

    @property
    def representative(self) -> str:
        return self.members[0]

    @property
    def lift_point(self) -> str:
        return f"{'external' if self.external else 'internal'} at x = {self.x_m:.1f} m"


@dataclass(frozen=True)
class FaultCase:
    """One single failure: ``bag`` fails by ``kind`` at the phase ``phase`` (``time_s`` [s]);
    ``represents`` the bags whose result it stands for (itself included)."""

    index: int
    bag: str
    kind: str
    phase: str
    time_s: float
    represents: tuple[str, ...]
    lift_point: str

    def fault(self) -> dict:
        """The scenario's ``faults:`` entry."""
        f = {"kind": self.kind, "bag": self.bag, "time_s": self.time_s}
        if self.kind == "bag_rupture":
            f["leak_time_s"] = LEAK_TIME_S
        return f

    def as_dict(self) -> dict:
        return {"index": self.index, "bag": self.bag, "kind": self.kind, "phase": self.phase,
                "time_s": self.time_s, "represents": list(self.represents),
                "lift_point": self.lift_point, "fault": self.fault()}


def kinds_of(external: bool) -> tuple[str, ...]:
    """The kinds that apply to a bag: all of :data:`KINDS` for an external bag, its loss only
    for an internal one."""
    return KINDS if external else ("bag_rupture",)


def noisy(scenario) -> bool:
    """Whether ``scenario`` has force or measurement noise (identical bags then differ)."""
    c, d = scenario.control, scenario.disturbance
    return (d.force_noise_N_m > 0 or c.height_noise_m > 0 or c.velocity_noise_m_s > 0
            or c.volume_noise_m3 > 0)


def groups(plant, all_bags: bool) -> list[Group]:
    """The bags in groups of identical ones at one lift point (by kind, point and capacity),
    or one group per bag (``all_bags``), in the plant's order."""
    out: dict[tuple, list[str]] = {}
    for i, name in enumerate(plant.names):
        ext = bool(plant.external[i])
        key = (i,) if all_bags else (ext, round(float(plant.x_point[i]), 3),
                                     round(float(plant.bags.capacity[i]), 6),
                                     int(plant.bags.group[i]))
        out.setdefault(key, []).append(name)
    return [Group(tuple(m), bool(plant.external[list(plant.names).index(m[0])]),
                  float(plant.x_point[list(plant.names).index(m[0])])) for m in out.values()]


def check_kinds(kinds, plant) -> tuple[str, ...]:
    """The kinds asked for, checked: an unknown one, or one no bag of the plan has the part
    for, is one line."""
    if not kinds:
        raise InputError("--kinds", "", f"name at least one kind: {', '.join(KINDS)}")
    for k in kinds:
        if k not in KINDS:
            raise InputError("--kinds", k, f"use {', '.join(KINDS)}")
        if not any(k in kinds_of(bool(e)) for e in plant.external):
            raise InputError("--kinds", k, f"the plan has no bag with a {PART[k]} of its own "
                             "(its internal bags have no valves, sling, supply or sensors): "
                             "use bag_rupture")
    return tuple(dict.fromkeys(kinds))


def make_cases(plant, phases, kinds=KINDS, all_bags: bool = False) -> tuple[list[FaultCase],
                                                                          list[Group]]:
    """Every applicable (bag, kind, phase) of the plan, and the groups (``phases``: the
    reached ones, :class:`~flexlift.sweep.contingency.phases.Phase`)."""
    gs = groups(plant, all_bags)
    cases = []
    for g in gs:
        for kind in kinds:
            if kind not in kinds_of(g.external):
                continue
            for ph in phases:
                if ph.time_s is None:
                    continue
                cases.append(FaultCase(len(cases), g.representative, kind, ph.name,
                                       float(ph.time_s), g.members, g.lift_point))
    return cases, gs
