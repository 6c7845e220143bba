"""The master controller on the network's readings: the coordinated laws of
:mod:`flexlift.control.controller` (the same compiled sample the simulation runs, no copy),
fed each control period from the :class:`~flexlift.live.board.Board`.

Where every bag has a depth gauge and a load cell and the seabed is one holding group, the
laws' heights, speeds and separation come from the hull observer
(:class:`~flexlift.live.hull.HullTrack`: the plant's rigid modes driven by the load cells'
forces, the seabed's hold law on the measured uplift; docs/reference/live.md#the-hull-observer)
and each volume from a scalar filter of its load cell (:class:`~flexlift.live.hull.
VolumeTrack`): with every sensor at 10 Hz the tanker is lifted safe
(docs/reference/live.md#what-it-achieves). Otherwise, what the laws take, from what the bags
report, through a Kalman filter per bag (:class:`~flexlift.live.track.BagTrack`;
docs/reference/live.md#the-master-controller):

- height z [m] above the bag point's rest level (the mean depth of its pressure gauge while
  held), and upward speed [m/s]: the filter's, predicted to the control sample;
- gas volume V [m^3]: the filter's, from the load cell, the sling force being the bag's
  buoyancy (its drag at the ascent's speeds is below a thousandth of it): V = F / (rho g),
  the inverse of :func:`flexlift.physics.gas.buoyancy`;
- separated: the filtered bag point has risen
  :data:`~flexlift.live.track.SEPARATED_RISE_M` above its rest level (the plant's own moment
  of separation is not on the network).
"""

from __future__ import annotations

import numpy as np

from flexlift.ascent.plant import coupled_plant
from flexlift.control.build import controller_for, fuzzy_maps
from flexlift.control.controller import sample
from flexlift.live.hull import HullTrack, VolumeTrack
from flexlift.live.track import VOLUME_RATE_SD, BagTrack
from flexlift.physics.gas import buoyancy
from flexlift.scenario.sensors import DEFAULT_FOR_LOG
from flexlift.sensors.config import HULL, sensors_of


class Master:
    """The coordinated controllers of ``scenario``'s external bags, sampled from outside."""

    def __init__(self, scenario, plant=None, mode: str = "coordinated"):
        self.plant = plant or coupled_plant(scenario)
        table, _, fill = fuzzy_maps(scenario, "table")
        self.controllers, self.state = controller_for(scenario, self.plant, mode, table, fill)
        self.bags = [self.plant.names[i] for i in self.controllers.bags]
        self.period = float(self.controllers.period)
        self.rho_g = float(self.plant.records.bags.rho_g)
        nc = len(self.bags)
        depth_sd, force_sd = reading_noise(scenario)
        self.tracks = [BagTrack(depth_sd, force_sd / buoyancy(1.0, self.rho_g))
                       for _ in range(nc)]
        self.separated = np.zeros(nc, dtype=np.bool_)
        self._z, self._zd, self._V = np.zeros(nc), np.zeros(nc), np.zeros(nc)
        self.hull = None  # the hull observer, where the lift's sensors allow it
        if hull_observable(scenario, self.plant):
            pitch_sd = reading_noise(scenario, "pitch")
            self.hull = HullTrack(self.plant, depth_sd, pitch_sd, force_sd)
            self.volumes = [VolumeTrack(force_sd / buoyancy(1.0, self.rho_g), VOLUME_RATE_SD)
                            for _ in range(nc)]
            self._columns = [self.plant.names.index(b) for b in self.bags]

    def inputs(self, board, t: float) -> bool:
        """The laws' inputs at lift time ``t`` [s] from ``board``; False while some
        controlled bag has no depth or sling force yet (then nothing is commanded)."""
        if self.hull is not None:
            return self._hull_inputs(board, t)
        for j, bag in enumerate(self.bags):
            depth, force = _gauge_and_cell(board, bag)
            if depth is None or force is None:
                return False
            track = self.tracks[j]
            volume = max(force[1], 0.0) / buoyancy(1.0, self.rho_g)
            if track.t is None:
                track.start(min(depth[0], force[0]), depth[1], volume)
            for t_d, d in board.heights[bag]:  # every depth since the last sample, in order
                track.depth(t_d, d)
            track.volume(force[0], volume)
            self._z[j], self._zd[j], self._V[j], _ = track.now(t)
            self.separated[j] = track.separated
        return True

    def _hull_inputs(self, board, t: float) -> bool:
        hull = self.hull
        readings = []
        for bag in hull.names:
            depth, force = _gauge_and_cell(board, bag)
            if depth is None or force is None:
                return False
            readings += [(t_d, 0, bag, d) for t_d, d in board.heights[bag]]
            readings.append((force[0], 1, bag, force[1]))
        pitch = board.last.get(f"{HULL}/pitch")
        if pitch is not None:
            readings.append((pitch[0], 2, HULL, pitch[1]))
        for when, kind, bag, value in sorted(readings):  # in time order, forces first
            if kind == 0:
                hull.depth(bag, when, value)
            elif kind == 1:
                hull.force(bag, when, value)
            else:
                hull.pitch(when, value)
        z, zd = hull.now(t)
        for j, bag in enumerate(self.bags):
            force = board.last[f"{bag}/sling_force"]
            self.volumes[j].volume(force[0], max(force[1], 0.0) / buoyancy(1.0, self.rho_g))
            self._z[j], self._zd[j] = z[self._columns[j]], zd[self._columns[j]]
            self._V[j] = self.volumes[j].V
        self.separated[:] = hull.separated
        return True

    def step(self, t: float, board) -> dict | None:
        """One control sample at lift time ``t`` [s]: {bag: (fill [m^3/s], opening [-])},
        or None when the inputs are not all there."""
        if not self.inputs(board, t):
            return None
        sample(t, self._z, self._zd, self._V, self.separated, self.controllers, self.state)
        return {bag: (float(self.state.fill[j]), float(self.state.opening[j]))
                for j, bag in enumerate(self.bags)}

    def heights(self) -> dict:
        """The heights [m] of the last sample, by bag."""
        return dict(zip(self.bags, self._z.tolist()))


def hull_observable(scenario, plant) -> bool:
    """Whether the hull observer (:class:`~flexlift.live.hull.HullTrack`) can run: a depth
    gauge and a load cell at every bag, and the seabed one holding group."""
    have = {s.name for s in sensors_of(scenario, plant.names, for_log=True)}
    every = all(f"{b}/{q}" in have for b in plant.names for q in ("depth", "sling_force"))
    return every and plant.records.seabed.ng == 1


def reading_noise(scenario, quantity: str | None = None):
    """(depth [m], sling force [N]) standard deviations of the lift's gauges: its
    ``sensors:`` section's, else that section's defaults."""
    section = scenario.sensors if scenario.sensors is not None else DEFAULT_FOR_LOG
    if quantity is not None:  # one quantity's standard deviation (SI)
        return (getattr(section, quantity) or getattr(DEFAULT_FOR_LOG, quantity)).noise_si()
    spec = {q: getattr(section, q) or getattr(DEFAULT_FOR_LOG, q)
            for q in ("depth", "sling_force")}
    return spec["depth"].noise_si(), spec["sling_force"].noise_si()


def _gauge_and_cell(board, bag: str):
    """``bag``'s latest depth and sling-force readings on ``board``, each (time [s], value
    [SI]) or None while none has come."""
    return board.last.get(f"{bag}/depth"), board.last.get(f"{bag}/sling_force")
