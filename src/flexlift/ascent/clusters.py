"""Identical bags at one lift point share the work of the compiled loop (issue 24).

A plan of real bags puts many identical bags at each lift point (the tanker on 20 t bags:
181 bags at 13 points). Bags that nothing tells apart move, fill and vent alike, so the
compiled loop keeps one *loop bag* per set of them with its ``count`` of members
(:class:`~flexlift.ascent.records.Bags`): its gas, pressure, volume and controller are one
member's, and what it does to the structure is ``count`` times that (the columns of the
generalised forces scaled, the sums over the bags weighted). One loop, never a second one.

Two bags share a loop bag only when everything the loop knows of them is equal
(:func:`cluster_key`): every per-bag field of the plant's bag record
(:func:`flexlift.ascent.records.bag_axis`: a field added to the record splits bags that differ
in it, with no change here), their start (neutral) volume, kind, point and span, the constants
of their controllers (every per-controller field of
:class:`~flexlift.control.controller.ControlArrays`), and their holding group (a field of the
record). A bag named by a scenario fault is a loop bag of its own (the others of its point stay
together), and with measurement noise (a draw per bag) no bags are merged.

The results stay per bag: :func:`expand` turns the loop's records (the recorded rows, the
state, the switches, the events) back into one entry per bag after the run, outside the loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexlift.ascent.records import BAG_COLUMNS, PlantRecords, bag_axis
from flexlift.ascent.state import EV_ARRIVAL, EV_LIMIT_DESCENT, EV_LIMIT_VELOCITY, EV_SURFACE_BREACH

#: events that name a bag (their index is a bag's); an arrival is every member's, the others
#: (the first bag found) the first member's
BAG_EVENTS = (EV_ARRIVAL, EV_SURFACE_BREACH, EV_LIMIT_VELOCITY, EV_LIMIT_DESCENT)
#: fields of :class:`~flexlift.control.controller.ControlArrays` over the controllers that
#: are not a controller's own constants
CONTROL_SHARED = ("bags", "ref_z", "ref_v", "table", "fill_v")


@dataclass(frozen=True)
class Clusters:
    """Which bags of a plant the compiled loop keeps as one.

    of_bag : (nb,) int, the loop bag each of the plant's bags is a member of
    first : (nl,) int, each loop bag's first member (increasing: the loop's bags in the
        plant's order of their first members)
    count : (nl,) float, the members of each loop bag
    """

    of_bag: np.ndarray
    first: np.ndarray
    count: np.ndarray

    @property
    def shared(self) -> bool:
        """Some loop bag stands for more than one bag."""
        return self.first.size < self.of_bag.size

    def members(self, j: int) -> np.ndarray:
        """The plant's bags of loop bag ``j``, in order."""
        return np.flatnonzero(self.of_bag == j)


def no_clusters(nb: int) -> Clusters:
    """One loop bag per bag."""
    return Clusters(of_bag=np.arange(nb), first=np.arange(nb), count=np.ones(nb))


def cluster_key(plant, controllers, i: int) -> bytes:
    """What the compiled loop knows of bag ``i`` of ``plant`` with ``controllers``
    (:class:`~flexlift.control.controller.ControlArrays`), as bytes: equal keys, identical
    bags."""
    bags = plant.bags
    parts = []
    for name, value in zip(bags._fields, bags):
        ax = bag_axis(name, value, bags.nb)
        if ax is not None and name != "count":
            parts.append(np.ascontiguousarray(np.take(value, i, axis=ax)).tobytes())
    parts += [np.float64(plant.neutral_volume[i]).tobytes(), bytes([bool(plant.external[i])]),
              np.float64(plant.x_point[i]).tobytes(), repr(plant.spans[i]).encode()]
    ctrl = np.flatnonzero(controllers.bags == i)
    if ctrl.size:
        nc = controllers.bags.size
        for name, value in zip(controllers._fields, controllers):
            if (isinstance(value, np.ndarray) and value.ndim and value.shape[0] == nc
                    and name not in CONTROL_SHARED):
                parts.append(np.ascontiguousarray(value[ctrl[0]]).tobytes())
    else:
        parts.append(b"no controller")
    return b"\x00".join(len(p).to_bytes(4, "little") + p for p in parts)


def cluster_keys(plant, controllers) -> list[bytes]:
    """:func:`cluster_key` of every bag of ``plant``, the same bytes, each per-bag field laid
    out bag by bag once (not taken again for each bag: a 73-bag plan's keys in a fifth of the
    time)."""
    bags = plant.bags
    nb = len(plant.names)
    rows = []  # per field: its values bag by bag (bag axis first, contiguous)
    for name, value in zip(bags._fields, bags):
        ax = bag_axis(name, value, bags.nb)
        if ax is not None and name != "count":
            rows.append(np.ascontiguousarray(np.moveaxis(value, ax, 0)))
    nc = controllers.bags.size
    ctrl_rows = [value for name, value in zip(controllers._fields, controllers)
                 if (isinstance(value, np.ndarray) and value.ndim and value.shape[0] == nc
                     and name not in CONTROL_SHARED)]
    first_ctrl = {}
    for k, i in enumerate(controllers.bags.tolist()):
        first_ctrl.setdefault(i, k)
    out = []
    for i in range(nb):
        parts = [r[i].tobytes() for r in rows]
        parts += [np.float64(plant.neutral_volume[i]).tobytes(), bytes([bool(plant.external[i])]),
                  np.float64(plant.x_point[i]).tobytes(), repr(plant.spans[i]).encode()]
        k = first_ctrl.get(i)
        if k is not None:
            parts += [np.ascontiguousarray(v[k]).tobytes() for v in ctrl_rows]
        else:
            parts.append(b"no controller")
        out.append(b"\x00".join(len(p).to_bytes(4, "little") + p for p in parts))
    return out


def find_clusters(scenario, plant, controllers, share: bool = True) -> Clusters:
    """The loop bags of ``plant`` (module docstring); one per bag when ``share`` is False,
    with measurement noise, or when no two bags are alike."""
    nb = len(plant.names)
    c = scenario.control
    noisy = max(c.height_noise_m, c.velocity_noise_m_s, c.volume_noise_m3) > 0
    if not share or noisy or nb < 2:
        return no_clusters(nb)
    faulted = {f.bag for f in scenario.faults}
    of_bag = np.empty(nb, dtype=np.int64)
    seen: dict[bytes, int] = {}
    first: list[int] = []
    keys = cluster_keys(plant, controllers)
    for i, name in enumerate(plant.names):
        key = b"fault " + name.encode() if name in faulted else keys[i]
        j = seen.setdefault(key, len(first))
        if j == len(first):
            first.append(i)
        of_bag[i] = j
    return Clusters(of_bag=of_bag, first=np.array(first, dtype=np.int64),
                    count=np.bincount(of_bag, minlength=len(first)).astype(float))


def loop_records(records: PlantRecords, cl: Clusters) -> PlantRecords:
    """The plant's records as the compiled loop reads them with ``cl``: one bag per loop bag
    (its first member's rows), the generalised forces of its members summed."""
    if not cl.shared:
        return records
    bags = records.bags
    fields = {}
    for name, value in zip(bags._fields, bags):
        ax = bag_axis(name, value, bags.nb)
        if ax is None:
            fields[name] = value
            continue
        part = np.take(value, cl.first, axis=ax)
        if name in BAG_COLUMNS:  # the members' forces summed
            part = part * cl.count
        fields[name] = np.ascontiguousarray(part)
    fields["nb"] = int(cl.first.size)
    fields["count"] = cl.count.copy()
    return records._replace(bags=type(bags)(**fields))


def loop_controllers(controllers, cl: Clusters):
    """The controllers of the loop's bags: the first member's of each controlled loop bag,
    weighted by its count (``ControlArrays.weight``), their ``bags`` the loop's indices."""
    if not cl.shared:
        return controllers
    nc = controllers.bags.size
    keep = np.array([j for j in range(nc) if cl.first[cl.of_bag[controllers.bags[j]]]
                     == controllers.bags[j]], dtype=np.int64)
    fields = {}
    for name, value in zip(controllers._fields, controllers):
        if (isinstance(value, np.ndarray) and value.ndim and value.shape[0] == nc
                and name not in CONTROL_SHARED):
            fields[name] = np.ascontiguousarray(value[keep])
        else:
            fields[name] = value
    loop_bags = cl.of_bag[controllers.bags[keep]]
    fields["bags"] = loop_bags.astype(np.int64)
    fields["weight"] = controllers.weight[keep] * cl.count[loop_bags]
    return type(controllers)(**fields)


def expand(record, probe, cl: Clusters, rows: dict[int, int] | None = None):
    """``record`` (a named tuple of the run: the state, the switches, the recorded rows) with
    one entry per bag: every axis that runs over the loop's bags taken at each bag's loop bag.
    ``probe(n)`` builds a record of the same kind for ``n`` bags: the axes whose length
    changes with ``n`` are the bag axes (so a field added to the record is expanded too).
    ``rows``: {a buffer's length: the rows used}: a field over the bags whose first axis is
    such a buffer keeps only the rows used (the recorded rows, not the buffer's room)."""
    if not cl.shared:
        return record
    nl, nb = cl.first.size, cl.of_bag.size
    small, large = probe(nl), probe(nb)
    rows = rows or {}
    fields = {}
    for name, value, a, b in zip(record._fields, record, small, large):
        if isinstance(value, np.ndarray) and isinstance(a, np.ndarray) and a.shape != b.shape:
            axes = [k for k, (m, n) in enumerate(zip(a.shape, b.shape)) if m != n]
            if axes[0] > 0 and value.shape[0] in rows:
                value = value[:rows[value.shape[0]]]
            for ax in axes:
                value = np.take(value, cl.of_bag, axis=ax)
        fields[name] = value
    return type(record)(**fields)


def expand_events(recorder, cl: Clusters):
    """The recorded events with bag indices of the plant: a loop bag's arrival becomes each
    member's (in order), its other events its first member's (the first bag found, as a loop
    over the bags finds it); at most as many as the record holds."""
    if not cl.shared:
        return recorder
    n = int(recorder.counts[2])
    rows = []
    for k in range(n):
        code, j = int(recorder.ev_code[k]), int(recorder.ev_index[k])
        row = (recorder.ev_t[k], code, j, recorder.ev_value[k])
        if code == EV_ARRIVAL and j >= 0:
            rows += [(row[0], code, int(i), row[3]) for i in cl.members(j)]
        elif code in BAG_EVENTS and j >= 0:
            rows.append((row[0], code, int(cl.first[j]), row[3]))
        else:
            rows.append(row)
    size = recorder.ev_t.size
    rows = rows[:size]
    ev_t, ev_code = np.zeros(size), np.zeros(size, np.int64)
    ev_index, ev_value = np.zeros(size, np.int64), np.zeros(size)
    for k, (t, code, i, v) in enumerate(rows):
        ev_t[k], ev_code[k], ev_index[k], ev_value[k] = t, code, i, v
    counts = recorder.counts.copy()
    counts[2] = len(rows)
    return recorder._replace(ev_t=ev_t, ev_code=ev_code, ev_index=ev_index, ev_value=ev_value,
                             counts=counts)
