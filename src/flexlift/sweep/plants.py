"""Plants reused across the cases a worker runs, whenever nothing they were built from changed.

Building the tanker's plant (lift plan, dry and wet modes, plant arrays) costs about a tenth
of its ascent; most sweeps vary keys the plant does not read at all (the current, the control
gains, the limits) or only partly (the breakout time and the drag coefficient enter the plant
arrays, not the lift plan). So each worker keeps its recent lift plans and plants, each with
the scenario values it was built from, found by *reading* them: the first build of a plan or
a plant runs on a scenario that records every dotted key the building code reads
(:class:`_Reading`). A later case whose scenario has the same values at every one of those keys
gets the same object: the builders are deterministic functions of what they read, so this is
exactly the plant a fresh build would give (the tests check it bit for bit), whatever the
builders come to read in future versions, with no list of keys kept here.

A reused plant is only read by :func:`flexlift.ascent.simulate` (its arrays are the compiled
loop's read-only inputs). The caches are per process (thread-safe), small and
least-recently-used.
"""

from __future__ import annotations

import pickle
import threading
from collections import OrderedDict

from pydantic import BaseModel

#: plans and plants kept per worker process
SIZE = 8
_WHOLE = ""


class _Reading:
    """A read-only view of a scenario (or one of its sections) that records the dotted keys
    read through it in ``log``: a section read returns another view, anything else is
    recorded. A method, or pydantic's own machinery, records the whole section."""

    __slots__ = ("_obj", "_path", "_log")

    def __init__(self, obj, path: str, log: set):
        object.__setattr__(self, "_obj", obj)
        object.__setattr__(self, "_path", path)
        object.__setattr__(self, "_log", log)

    def __getattr__(self, name: str):
        value = getattr(self._obj, name)
        key = f"{self._path}.{name}" if self._path else name
        if name.startswith(("_", "model_")) or callable(value):
            self._log.add(self._path)  # the whole section (or scenario) is read
            return value
        if isinstance(value, BaseModel):
            return _Reading(value, key, self._log)
        self._log.add(key)
        return value

    def __setattr__(self, name, value):  # pragma: no cover - the builders never write
        raise AttributeError("a scenario is read only")


#: the value of a key inside an optional section the scenario does not have (``pipe.*``)
_ABSENT = ("absent",)


def _value(scenario, key: str):
    obj = scenario
    if key:
        for part in key.split("."):
            if obj is None:
                return _ABSENT
            obj = getattr(obj, part)
    return _canonical(obj)


def _canonical(v):
    """A value as a hashable, exactly comparable form (floats by their bits: -0.0 is not 0.0;
    a section, or each bag of a list of them, as the pickle of its values: floats as their
    eight bytes, 1 not 1.0, None not NaN; a value shared twice inside it can only make two
    equal sections compare unequal, a new build, never the reverse)."""
    if isinstance(v, BaseModel):
        return ("model", type(v).__name__, pickle.dumps(v.model_dump(mode="python"), protocol=5))
    if isinstance(v, dict):
        return ("dict", tuple((k, _canonical(x)) for k, x in v.items()))
    if isinstance(v, list | tuple):
        return ("list", tuple(_canonical(x) for x in v))
    if isinstance(v, float):
        return ("float", v.hex())
    return (type(v).__name__, v)


class ReadMemo:
    """Results of a deterministic function of a scenario, each kept with the values of the
    keys its computation read; :meth:`get` returns the result whose keys all hold the same
    values in ``scenario``, else builds (and keeps) a new one. Results are grouped by the
    set of keys they read (nearly always one set), so a lookup reads each key once."""

    def __init__(self, size: int = SIZE):
        self.size = size
        self._groups: dict[tuple[str, ...], dict] = {}  # keys read -> {their values: result}
        self._order: OrderedDict[tuple, None] = OrderedDict()  # (keys, values), oldest first
        self._lock = threading.Lock()
        self.hits = self.misses = 0

    def get(self, scenario, build, salt=None):
        """``build(view)`` -> (result, extra keys), computed on a recording view of
        ``scenario`` unless a kept result was built from the same values (and the same
        ``salt``: what else the build reads, compared by equality); returns (result, the keys
        it depends on)."""
        with self._lock:
            groups = list(self._groups.items())
        seen: dict[str, object] = {}  # each key's value read once (a miss reads them again)

        def values_of(keys):
            for k in keys:
                if k not in seen:
                    seen[k] = _value(scenario, k)
            return tuple(seen[k] for k in keys) + (salt,)

        for keys, kept in groups:
            values = values_of(keys)
            with self._lock:
                if values in kept:
                    self._order.move_to_end((keys, values))
                    self.hits += 1
                    return kept[values], keys
        log: set[str] = set()
        result, extra = build(_Reading(scenario, "", log))
        keys = tuple(sorted(log | set(extra)))
        if _WHOLE in keys:
            keys = (_WHOLE,)
        values = values_of(keys)
        with self._lock:
            self.misses += 1
            self._groups.setdefault(keys, {})[values] = result
            self._order[(keys, values)] = None
            while len(self._order) > self.size:
                k, v = self._order.popitem(last=False)[0]
                del self._groups[k][v]
                if not self._groups[k]:
                    del self._groups[k]
        return result, keys

    def keys(self) -> list[tuple[str, ...]]:
        """The sets of keys the kept results were built from."""
        return list(self._groups)


_PLANS, _PLANTS, _PAPER, _GEOMETRY = ReadMemo(), ReadMemo(), ReadMemo(), ReadMemo()
#: the dry and wet modes of the plans and plants (:func:`~flexlift.structure.modes.reusing_modes`)
_MODES: dict = {}


def plan_salt(plan) -> bytes:
    """What a plant's geometry reads of a lift plan (:data:`~flexlift.ascent.plant.
    GEOMETRY_READS`: the bags and the wet weight, not the required lift, the modelled lift
    per bag or the warnings, which the scenario's ``lift.breakout_factor`` changes), as
    bytes compared exactly."""
    from flexlift.ascent.plant import GEOMETRY_READS

    return pickle.dumps(tuple(getattr(plan, name) for name in GEOMETRY_READS), protocol=5)


def plant_for(scenario, mode: str):
    """The plant ``simulate(scenario, control=mode)`` would build (the paper's in paper mode,
    else the coupled one), reused when it can be; else built on the kept geometry of the same
    hull and plan when there is one (the modes, strips and bag points: a case that changes the
    gas, the seabed's hold or the breakout factor rebuilds only the bags' and the seabed's
    records)."""
    from flexlift.ascent.paper import paper_plant
    from flexlift.ascent.plant import coupled_plant, plant_geometry
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario
    from flexlift.structure.modes import reusing_modes

    with reusing_modes(_MODES):
        plan, plan_keys = _PLANS.get(scenario,
                                     lambda v: (plan_lift(v, hull_from_scenario(v)), ()))
        geometry, geo_keys = _GEOMETRY.get(
            scenario, lambda v: (plant_geometry(v, hull_from_scenario(v), plan), ()),
            salt=plan_salt(plan))

        def coupled(v):
            return coupled_plant(v, plan=plan, geometry=geometry)

        if mode == "paper":
            return _PAPER.get(scenario, lambda v: (paper_plant(v, coupled(v)),
                                                   plan_keys + geo_keys))[0]
        return _PLANTS.get(scenario, lambda v: (coupled(v), plan_keys + geo_keys))[0]


def stats() -> dict:
    """Hits and misses of this process's caches (for the benchmark)."""
    out = {name: {"hits": m.hits, "misses": m.misses}
           for name, m in (("plans", _PLANS), ("plants", _PLANTS), ("paper", _PAPER),
                           ("geometry", _GEOMETRY))}
    out["modes_kept"] = len(_MODES)
    return out
