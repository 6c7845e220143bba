"""What the master controller takes of the whole hull, from every bag's readings and the
plant's own model: a Kalman filter of the hull's rigid motion driven by the physics, and the
seabed's hold run on the load cells (docs/reference/live.md#the-hull-observer).

Why (measured, docs/reference/live.md#what-it-achieves): the coordinated laws need each bag's
speed within about 0.3 s and 0.01 m/s, and the separation within about 1.5 s. A filter of
one bag's depths alone cannot give both (0.02 m gauges, even at 10 Hz); this one uses what
the master knows besides the depths:

- **Motion model: the plant's rigid modes.** State x = [q_h, q_p, v_h, v_p, b_h, b_p]: the
  heave and pitch modal coordinates of :func:`flexlift.ascent.plant.coupled_plant` (mass
  normalised, the added mass in them), their rates, and a slowly wandering bias of their
  accelerations [per modal coordinate]. Free, q'' = Q + b with Q the generalised force of
  every bag's sling force as its load cell reads it (the bag's buoyancy and drag), the wet
  weight, the hull's drag on the filter's own speed and the released suction of the
  separated seabed, H_sep exp(-(t - t_sep) / tau_r) in the plant's shape; so the speed
  follows the bags' gas as it changes, not the depths' differences, and is not late.
  The flexible modes (above 2.5 Hz) are left out: their static deflection under these loads
  is below a millimetre at the bag points.
- **Measurements.** Each bag's depth gauge measures its point's height above its rest level
  (the mean depth while held), shape_i . q; the hull's inclinometer (``hull/pitch``)
  measures the pitch above its rest level; each at its own time, in time order.
- **Held** (before the separation): the hull does not move; the filter only learns the rest
  levels. The seabed's hold is the scenario's law (:func:`flexlift.physics.seabed.
  holding_rate`) run on the net uplift U = sum of the sling forces - the hull's wet weight;
  **separated** once U, smoothed over :data:`UPLIFT_TAU_S`, exceeds that hold by
  :data:`HOLD_SIGMAS` standard deviations of the smoothed U (the plant's
  own rule, :func:`flexlift.ascent.kernel.separations`), or, should the seabed hold less
  than its law says, once the bags' mean rise over the last :data:`RISE_WINDOW_S` exceeds
  :data:`RISE_SIGMAS` standard deviations of that mean (one-sided: a false alarm about once
  in 3.5 million tests, one a control period) and :data:`MIN_RISE_M`.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from flexlift.physics.seabed import holding_rate

#: white acceleration of the free model's heave and pitch [m/s^2 at a bag point]
ACCEL_SD = 0.002
#: random walk of the acceleration bias [m/s^2 per sqrt(s)]
BIAS_RATE_SD = 2e-4
#: first standard deviations of the free filter: speed [m/s] and bias [m/s^2]
FIRST_SPEED_SD, FIRST_BIAS_SD = 0.005, 0.002
#: the uplift is smoothed by a first-order low pass of this time constant [s]
UPLIFT_TAU_S = 10.0
#: separated once the smoothed uplift exceeds the hold by this many of its standard
#: deviations (the load cells' noise through the low pass): a flag before the plant's own
#: separation takes the pull away and the hull stays held (measured: the plant's uplift fell
#: from 1.47 to 1.13 MN in 5 s and it did not separate); 3 of them cost about 0.8 s
HOLD_SIGMAS = 3.0
#: rise test: the bags' mean height above rest over this window [s] ...
RISE_WINDOW_S = 1.0
#: ... beyond this many standard deviations of that mean ...
RISE_SIGMAS = 5.0
#: ... and this many metres
MIN_RISE_M = 0.02
#: the rest levels are the mean of at least this many readings of each gauge
REST_READINGS = 10
#: a noise-free sensor is taken with this standard deviation (a filter needs R > 0)
MIN_SD = 1e-4
#: number of rigid modes (heave, pitch): the plant's first two
RIGID = 2


class HullTrack:
    """The hull observer of ``plant`` (:class:`flexlift.ascent.plant.Plant`) with gauges of
    ``depth_sd`` [m] and an inclinometer of ``pitch_sd`` [rad]."""

    def __init__(self, plant, depth_sd: float, pitch_sd: float, force_sd: float):
        rec = plant.records
        self.names = list(plant.names)
        self.index = {b: i for i, b in enumerate(self.names)}
        self.shape = np.ascontiguousarray(rec.bags.shape[:, :RIGID])  # (nb, 2) m per q
        self.bag_force = np.ascontiguousarray(rec.bags.force[:RIGID])  # (2, nb)
        self.weight = np.asarray(rec.modal.weight_force[:RIGID], dtype=float)
        self.strip_shape = np.ascontiguousarray(rec.strips.shape[:, :RIGID])
        self.strip_force = np.ascontiguousarray(rec.strips.force[:RIGID])
        self.strip_drag = np.asarray(rec.strips.drag, dtype=float)
        self.pitch_row = np.asarray(rec.modal.pitch_row[:RIGID], dtype=float)
        self.seabed = rec.seabed
        self.hold_shape = np.asarray(rec.seabed.hold_force[:RIGID, 0], dtype=float)
        self.H = float(np.sum(rec.seabed.H0))  # the hold left [N]: one group (else refused)
        self.H0 = self.H
        self.group_weight = float(np.sum(rec.seabed.group_weight))
        self.count = np.asarray(rec.bags.count, dtype=float)
        self.depth_sd, self.pitch_sd = max(depth_sd, MIN_SD), max(pitch_sd, MIN_SD)
        nb = len(self.names)
        self.rest = np.zeros(nb)
        self.at_rest = np.zeros(nb, dtype=int)
        self.pitch_rest, self.pitch_at_rest = 0.0, 0
        self.forces = np.full(nb, np.nan)  # the latest sling force of each bag [N]
        self.uplift: float | None = None  # smoothed net uplift [N]
        self.uplift_var = 0.0  # its variance from the load cells' noise [N^2]
        self.force_var = float(np.sum(self.count ** 2)) * force_sd ** 2  # of one sum [N^2]
        self.t_uplift: float | None = None
        self.held = True
        self.t_sep: float | None = None
        self.H_sep = 0.0
        self.how: str | None = None  # "hold" or "rise": what told the separation
        self.t: float | None = None  # the filter's time [s]
        self.x = np.zeros(3 * RIGID)
        self.P = np.zeros((3 * RIGID, 3 * RIGID))
        self.last_depth = np.full(nb, -math.inf)
        self.last_pitch = -math.inf
        self.recent = deque()  # (time, mean rise) of the held bags' readings
        self._rise_sum = 0.0  # the sum of the rises in ``recent`` [m]
        # white acceleration at a bag point [m/s^2] -> per modal coordinate
        scale = float(np.max(np.abs(self.shape), axis=0).min())
        self.q_accel = (ACCEL_SD / scale) ** 2
        self.q_bias = (BIAS_RATE_SD / scale) ** 2
        self.first_v, self.first_b = FIRST_SPEED_SD / scale, FIRST_BIAS_SD / scale

    # -- held: the rest levels, the hold and the separation ---------------------------------

    def force(self, bag: str, t: float, value: float) -> None:
        """Take a sling force [N] of ``bag`` read at ``t`` [s]."""
        self.forces[self.index[bag]] = value
        if not self.held or np.isnan(self.forces).any():
            return
        U = float(np.sum(self.forces * self.count)) - self.group_weight
        if self.uplift is None:
            self.uplift, self.t_uplift, self.uplift_var = U, t, self.force_var
            return
        dt = t - self.t_uplift
        if dt <= 0.0:
            return
        # the hold on the raw uplift (the law's rate is linear in it: the noise integrates
        # away; on the smoothed one the low pass's lag during the fill left the hold 18 kN,
        # 5 s of its decay, above the plant's); the crossing on the smoothed one
        self.H = max(self.H + dt * holding_rate(U, self.H, self.H0, self.seabed), 0.0)
        a = 1.0 - math.exp(-dt / UPLIFT_TAU_S)
        self.uplift += a * (U - self.uplift)
        self.uplift_var = (1 - a) ** 2 * self.uplift_var + a * a * self.force_var
        self.t_uplift = t
        if self.uplift > self.H + HOLD_SIGMAS * math.sqrt(self.uplift_var):
            self._separate(t, "hold")

    def _separate(self, t: float, how: str) -> None:
        self.held, self.t_sep, self.how = False, t, how
        self.H_sep = self.H if how == "hold" else max(self.uplift or 0.0, 0.0)
        self.t = t
        self.x[:] = 0.0
        if self.recent:  # a rise already seen: start from it (heave only)
            self.x[0] = self.recent[-1][1] / self.shape[0, 0] if how == "rise" else 0.0
        self.P = np.diag([self.depth_sd ** 2 / self.shape[0, 0] ** 2] * RIGID
                         + [self.first_v ** 2] * RIGID + [self.first_b ** 2] * RIGID)

    def _held_depth(self, i: int, t: float, depth: float) -> None:
        if self.at_rest[i] < REST_READINGS or abs(self.rest[i] - depth) < 5 * self.depth_sd:
            self.at_rest[i] += 1
            self.rest[i] += (depth - self.rest[i]) / self.at_rest[i]
        if (self.at_rest < REST_READINGS).any():
            return
        rise = self.rest[i] - depth
        self.recent.append((t, rise))
        self._rise_sum += rise
        while self.recent and self.recent[0][0] < t - RISE_WINDOW_S:
            self._rise_sum -= self.recent.popleft()[1]
        # the window's sum kept as readings come and go (summed afresh, every bag's readings
        # over the window at every reading, it cost 73 bags at 10 Hz a sixth of a core)
        n = len(self.recent)
        mean = self._rise_sum / n
        sd = self.depth_sd / math.sqrt(n)
        if n >= 4 and mean > max(RISE_SIGMAS * sd, MIN_RISE_M):
            self._separate(t, "rise")

    # -- free: the Kalman filter ------------------------------------------------------------

    def _accel(self, t: float, v: np.ndarray) -> np.ndarray:
        """The rigid generalised accelerations [per modal coordinate] at ``t`` and rates ``v``."""
        Q = self.bag_force @ np.nan_to_num(self.forces * self.count) + self.weight
        wv = self.strip_shape @ v
        Q = Q + self.strip_force @ (-self.strip_drag * np.abs(wv) * wv)
        hold = self.H_sep * math.exp(-(t - self.t_sep) / self.seabed.release_time)
        return Q + self.hold_shape * hold

    def _step(self, x: np.ndarray, P: np.ndarray, t0: float, dt: float):
        n = RIGID
        a = self._accel(t0, x[n:2 * n]) + x[2 * n:]
        x = x.copy()
        x[:n] += dt * x[n:2 * n] + 0.5 * dt * dt * a
        x[n:2 * n] += dt * a
        F = np.eye(3 * n)
        F[:n, n:2 * n] = dt * np.eye(n)
        F[:n, 2 * n:] = 0.5 * dt * dt * np.eye(n)
        F[n:2 * n, 2 * n:] = dt * np.eye(n)
        Qn = np.zeros((3 * n, 3 * n))
        q = self.q_accel
        for k in range(n):
            Qn[k, k] = q * dt ** 3 / 3
            Qn[k, n + k] = Qn[n + k, k] = q * dt ** 2 / 2
            Qn[n + k, n + k] = q * dt
            Qn[2 * n + k, 2 * n + k] = self.q_bias * dt
        return x, F @ P @ F.T + Qn

    def _predict_to(self, t: float) -> None:
        if t > self.t:
            self.x, self.P = self._step(self.x, self.P, self.t, t - self.t)
            self.t = t

    def _update(self, h: np.ndarray, z: float, r: float) -> None:
        Ph = self.P @ h
        s = float(h @ Ph) + r
        k = Ph / s
        self.x = self.x + k * (z - float(h @ self.x))
        self.P = self.P - np.outer(k, Ph)

    # -- readings ---------------------------------------------------------------------------

    def depth(self, bag: str, t: float, depth: float) -> None:
        """Take a depth reading [m] of ``bag`` at ``t`` [s] (not newer than its last: left)."""
        i = self.index[bag]
        if t <= self.last_depth[i] or (self.t is not None and t < self.t):
            return
        self.last_depth[i] = t
        if self.held:
            self._held_depth(i, t, depth)
            return
        self._predict_to(t)
        h = np.zeros(3 * RIGID)
        h[:RIGID] = self.shape[i]
        self._update(h, self.rest[i] - depth, self.depth_sd ** 2)

    def pitch(self, t: float, value: float) -> None:
        """Take the hull's inclinometer reading [rad] at ``t`` [s]."""
        if t <= self.last_pitch or (self.t is not None and t < self.t):
            return
        self.last_pitch = t
        if self.held:
            self.pitch_at_rest += 1
            self.pitch_rest += (value - self.pitch_rest) / self.pitch_at_rest
            return
        if self.pitch_at_rest == 0:
            return
        self._predict_to(t)
        h = np.zeros(3 * RIGID)
        h[:RIGID] = self.pitch_row
        self._update(h, value - self.pitch_rest, self.pitch_sd ** 2)

    @property
    def separated(self) -> bool:
        return not self.held

    def now(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """(heights [m], upward speeds [m/s]) of every bag point at ``t`` [s]: 0 while held,
        else the filter predicted to ``t`` (the filter itself stays at its last reading)."""
        nb = len(self.names)
        if self.held:
            return np.zeros(nb), np.zeros(nb)
        x = self.x
        if t > self.t:
            x, _ = self._step(self.x, self.P, self.t, t - self.t)
        return self.shape @ x[:RIGID], self.shape @ x[RIGID:2 * RIGID]


class VolumeTrack:
    """A bag's gas volume [m^3] from its load cell: a scalar Kalman filter, the volume a
    random walk of :data:`flexlift.live.track.VOLUME_RATE_SD` per sqrt(s) (the valves change
    it), each sling force F read as V = F / (rho g) of standard deviation ``volume_sd``."""

    def __init__(self, volume_sd: float, rate_sd: float):
        self.r, self.q = max(volume_sd, MIN_SD) ** 2, rate_sd ** 2
        self.t: float | None = None
        self.V, self.P = 0.0, 0.0

    def volume(self, t: float, volume: float) -> None:
        """Take a volume [m^3] of time ``t`` [s] (not newer than the last: left)."""
        if self.t is None:
            self.t, self.V, self.P = t, volume, self.r
            return
        if t <= self.t:
            return
        self.P += self.q * (t - self.t)
        k = self.P / (self.P + self.r)
        self.V += k * (volume - self.V)
        self.P *= 1.0 - k
        self.t = t
