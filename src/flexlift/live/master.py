"""The master controller on the network's readings: the coordinated laws of
:mod:`flexlift.control.controller` (the same compiled sample the simulation runs, no copy),
fed each control period from the :class:`~flexlift.live.board.Board`.

What the laws take, from what the bags report
(docs/reference/live.md#the-master-controller):

- height z [m] above the bag point's start: the first depth reading minus the present one
  (the pressure gauge of the bag's lift point);
- upward speed [m/s]: the board's slope of the depths over its window;
- gas volume V [m^3]: the load cell, the sling force being the bag's buoyancy (its drag at
  the ascent's speeds is below a thousandth of it): V = F / (rho g), low-passed
  (:data:`VOLUME_GAIN`), the inverse of
  :func:`flexlift.physics.gas.buoyancy`;
- separated: the bag point has risen :data:`SEPARATED_RISE_M` (the plant's own moment of
  separation is not on the network).
"""

from __future__ import annotations

import numpy as np

from flexlift.ascent.plant import coupled_plant
from flexlift.control.build import controller_for, fuzzy_maps
from flexlift.control.controller import sample
from flexlift.physics.gas import buoyancy

#: a bag point risen this far above its start has separated from the seabed [m]
SEPARATED_RISE_M = 0.1
#: the volume from the load cell is low-passed, this gain per control sample: a reading held
#: between samples steps by its noise (5 kN, 0.5 m^3) once a second, which the deficit's rate
#: in the fill law would take as a fast change
VOLUME_GAIN = 0.1


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
        self.depth0 = np.full(nc, np.nan)
        self.separated = np.zeros(nc, dtype=np.bool_)
        self._z, self._zd, self._V = np.zeros(nc), np.zeros(nc), np.zeros(nc)

    def inputs(self, board) -> bool:
        """The laws' inputs from ``board``; False while some controlled bag has no depth or
        sling force yet (then nothing is commanded)."""
        for j, bag in enumerate(self.bags):
            depth = board.value(bag, "depth")
            force = board.value(bag, "sling_force")
            if depth is None or force is None:
                return False
            first = bool(np.isnan(self.depth0[j]))
            if first:
                self.depth0[j] = depth
            self._z[j] = self.depth0[j] - depth
            self._zd[j] = board.speed(bag) or 0.0
            volume = max(force, 0.0) / buoyancy(1.0, self.rho_g)
            self._V[j] = volume if first else self._V[j] + VOLUME_GAIN * (volume - self._V[j])
            self.separated[j] |= self._z[j] > SEPARATED_RISE_M
        return True

    def step(self, t: float, board) -> dict | None:
        """One control sample at lift time ``t`` [s]: {bag: (fill [m^3/s], opening [-])},
        or None when the inputs are not all there."""
        if not self.inputs(board):
            return None
        sample(t, self._z, self._zd, self._V, self.separated, self.controllers, self.state)
        return {bag: (float(self.state.fill[j]), float(self.state.opening[j]))
                for j, bag in enumerate(self.bags)}

    def heights(self) -> dict:
        """The heights [m] of the last sample, by bag."""
        return dict(zip(self.bags, self._z.tolist()))
