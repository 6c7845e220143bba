"""What the master controller takes of one bag, from its readings: a Kalman filter per bag
(filterpy's :class:`~filterpy.kalman.KalmanFilter`) on the depth gauge's and the load cell's
readings (docs/reference/live.md#the-master-controller).

State x = [h, h', V]: the height of the bag's lift point above its start [m], its upward
speed [m/s] and the bag's gas volume [m^3].

- **Model.** h and h' a constant speed driven by white acceleration of standard deviation
  :data:`ACCEL_SD` (filterpy's ``Q_discrete_white_noise``, piecewise constant over a step);
  V a random walk of standard deviation :data:`VOLUME_RATE_SD` per second (the fill and
  purge valves change it; their flows are commands, not readings, so they are not inputs).
- **Measurements.** A depth reading d measures h = d0 - d (d0 the first depth), standard
  deviation the gauge's ``sensors.depth.noise_m``; a sling force F measures V = F / (rho g)
  (the sling carries the bag's buoyancy), standard deviation ``sensors.sling_force.noise_N``
  / (rho g). Each reading is taken at its own time: the filter is predicted to it, then
  updated, in time order.
- **Output.** The estimate predicted to the control sample's time (no update): what the bag
  is doing now, not at its last reading, so neither the gauges' period nor their latency
  delays the speed the laws damp with.

Why (measured, docs/reference/live.md#what-it-achieves): the coordinated laws damp the ascent
and the pitch with the bags' speeds; a speed from the slope of the last 2 s of 1 Hz depths,
held between readings, lags the bag by about 1.5 s and sets the rate and pitch loops
oscillating into an unsafe ascent even with noise-free gauges.
"""

from __future__ import annotations

import math

import numpy as np
from filterpy.common import Q_discrete_white_noise
from filterpy.kalman import KalmanFilter

#: standard deviation of the white acceleration of the height's model [m/s^2]
ACCEL_SD = 0.1
#: standard deviation of the volume's random walk per second [m^3/s^0.5]
VOLUME_RATE_SD = 0.5
#: first variances: the height (its first reading defines it), speed and volume
FIRST_SPEED_SD, FIRST_VOLUME_SD = 0.05, 5.0
#: a bag risen this far above its rest level (filtered) has separated from the seabed [m]
SEPARATED_RISE_M = 0.1
#: the rest level is the mean of at least this many depths before a rise is judged
REST_READINGS = 10
#: a noise-free sensor is taken with this standard deviation (a filter needs R > 0)
MIN_SD = 1e-4

_H_DEPTH = np.array([[1.0, 0.0, 0.0]])
_H_VOLUME = np.array([[0.0, 0.0, 1.0]])


class BagTrack:
    """The Kalman filter of one bag; ``depth_sd`` [m] and ``volume_sd`` [m^3]: its
    readings' noise."""

    def __init__(self, depth_sd: float, volume_sd: float):
        self.kf = KalmanFilter(dim_x=3, dim_z=1)
        self.depth_sd, self.volume_sd = max(depth_sd, MIN_SD), max(volume_sd, MIN_SD)
        self.depth0: float | None = None  # the rest level: the mean depth while held [m]
        self.at_rest = 0  # the depths averaged into it
        self.held = True  # the rest level follows the readings until the bag separates
        self.t: float | None = None  # the filter's time [s]
        self.t_depth = -math.inf  # the last depth and volume readings taken [s]
        self.t_volume = -math.inf

    def start(self, t: float, depth: float, volume: float) -> None:
        """Begin at time ``t`` [s] from the first depth [m] and volume [m^3]."""
        self.depth0, self.t = depth, t
        self.kf.x = np.array([-depth, 0.0, volume])
        self.kf.P = np.diag([self.depth_sd ** 2, FIRST_SPEED_SD ** 2, FIRST_VOLUME_SD ** 2])

    def _matrices(self, dt: float) -> tuple[np.ndarray, np.ndarray]:
        F = np.array([[1.0, dt, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
        Q = np.zeros((3, 3))
        Q[:2, :2] = Q_discrete_white_noise(2, dt=dt, var=ACCEL_SD ** 2)
        Q[2, 2] = VOLUME_RATE_SD ** 2 * dt
        return F, Q

    def _predict_to(self, t: float) -> None:
        if t > self.t:
            F, Q = self._matrices(t - self.t)
            self.kf.predict(F=F, Q=Q)
            self.t = t

    def depth(self, t: float, depth: float) -> None:
        """Take a depth reading [m] of time ``t`` [s] (older than the filter's time: left)."""
        if t <= self.t_depth or t < self.t:
            return
        self._predict_to(t)
        self.kf.update(np.array([-depth]), R=self.depth_sd ** 2, H=_H_DEPTH)
        self.t_depth = t
        if self.held and self.at_rest >= REST_READINGS and self.risen() > SEPARATED_RISE_M:
            self.held = False  # separated: the rest level stays where it is
        if self.held:
            self.at_rest += 1
            self.depth0 += (depth - self.depth0) / self.at_rest

    def volume(self, t: float, volume: float) -> None:
        """Take a volume [m^3] (from a sling force) of time ``t`` [s]."""
        if t <= self.t_volume or t < self.t:
            return
        self._predict_to(t)
        self.kf.update(np.array([volume]), R=self.volume_sd ** 2, H=_H_VOLUME)
        self.t_volume = t

    def risen(self) -> float:
        """The rise [m] above the rest level at the last depth reading, as filtered (no
        extrapolation: a separation is judged on what the gauge saw); 0 until
        :data:`REST_READINGS` depths define the rest level."""
        if self.at_rest < REST_READINGS and self.held:
            return 0.0
        return float(self.kf.x[0]) + self.depth0

    @property
    def separated(self) -> bool:
        """Whether the bag has risen :data:`SEPARATED_RISE_M` above its rest level."""
        return not self.held

    def now(self, t: float) -> tuple[float, float, float, float]:
        """(height [m], speed [m/s], volume [m^3], the height's standard deviation [m])
        predicted to ``t`` [s] (the filter itself stays at its last reading)."""
        dt = max(t - self.t, 0.0)
        F, Q = self._matrices(dt)
        x = F @ self.kf.x
        P = F @ self.kf.P @ F.T + Q
        return (float(x[0]) + self.depth0, float(x[1]), float(x[2]),
                math.sqrt(max(P[0, 0], 0.0)))
