"""The lift's state from its readings: the ensemble Kalman filter on the plant
(docs/theory/estimation.md#filter).

:class:`Estimator` keeps an :class:`~flexlift.estimate.ensemble.Ensemble` of runs of the
compiled loop. :meth:`Estimator.assimilate` takes the readings of one window (their own
times, any order): the members advance together to the window's end, each member's
readings are predicted from its own recorded rows by the sensors' own law
(:func:`flexlift.sensors.truth.true_values`, interpolated at each reading's time), and the
ETKF (:func:`flexlift.estimate.enkf.analysis`) moves the members' columns towards the
readings. What each reading was predicted to be (mean and spread) is returned for the fault
detector. A reading more than :data:`GATE` standard deviations from its prediction is not
assimilated (a fault, or a sensor's own failure, must not drag the state): it is counted
and passed on.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from flexlift.ascent.loop import COMMANDED
from flexlift.ascent.result import BAG_VARS, HULL_VARS
from flexlift.estimate.enkf import analysis
from flexlift.estimate.ensemble import PARTS, Ensemble, Prior
from flexlift.physics.gas import moles_rate, purge_flow
from flexlift.sensors.truth import true_values

_BAG = {name: j for j, name in enumerate(BAG_VARS)}
_HULL = {name: j for j, name in enumerate(HULL_VARS)}
#: the quantities the filter assimilates (the others are the fault detector's)
OBSERVED = ("depth", "pitch", "sling_force")
#: the least standard deviation a reading is given in the update, by quantity [SI]: a
#: sensor declared noiseless is not believed past the plant's own accuracy
NOISE_FLOOR = {"depth": 0.02, "pitch": 2.0e-4, "sling_force": 200.0, "purge": 0.05}
#: the valves' feedback that weighs the members in resampling, not in the update: a member
#: running the scenario's controller sets its valves as the lift's does only if its state is
#: the lift's (at separation the dump valves open: the one reading that tells it at once).
#: The fill flow is left out: weighed too, the members' gas collapsed below the load cells'
#: own band in the pull (tests/test_estimator.py's noisy pull)
FEEDBACK = ("purge",)
#: a reading this many predicted standard deviations off is not assimilated
GATE = 6.0
#: a member whose motion readings are off by this many standard deviations (root mean
#: square) has lost the lift: the members are resampled whatever their effective number
OUTLIER = 3.0
#: the window's predictions are not to be judged by (:attr:`Estimator.lost`) when more than
#: this share of the members have lost the lift (:data:`OUTLIER`), or the ensemble was widened
LOST_SHARE = 0.5
#: the most a lost ensemble's motion spread is widened by at one update [-]
WIDEN_MAX = 2.0
#: a valve's own accuracy [-], process noise that keeps the members' gas spread from
#: collapsing below what the load cells can tell: commanded members' fill is the command
#: times (1 + e), e ~ N(0, this) drawn per member and command (its timing:
#: :meth:`Estimator.command`'s ``delay_s``); every member's gas is moved by this fraction of
#: what its fill and purge moved in each window (:meth:`Ensemble.valve_noise`)
FILL_SPREAD = Prior().valve
#: relaxation to the prior's perturbations (RTPP, Zhang et al. 2004): the members' anomalies
#: after each update are this fraction theirs before it, the rest theirs after [-] (keeps the
#: ensemble from collapsing; a convex mixture, so it never inflates what readings do not see)
RELAXATION = 0.5


@dataclass
class Prediction:
    """A reading and what the ensemble predicted it to be: ``mean`` and ``std`` (the
    members' spread with the sensor's noise), ``used`` in the update or not."""

    time_s: float
    sensor: str
    value: float
    mean: float
    std: float
    used: bool


@dataclass
class Counts:
    """What the estimator did with the readings it was given."""

    assimilated: int = 0
    gated: int = 0
    not_observed: int = 0
    late: int = 0
    updates: int = 0
    resampled: int = 0
    widened: int = 0
    lost_windows: int = 0
    released: int = 0
    rejected: int = 0
    by_sensor_gated: dict = field(default_factory=dict)


class Estimator:
    """The filter over ``sensors`` (:class:`flexlift.sensors.config.Sensor`) of
    ``scenario``.

    Parameters
    ----------
    scenario : Scenario
    sensors : list of Sensor
    members : int, optional
        Ensemble size (default 24).
    seed : int, optional
    prior : Prior, optional
    control : str, optional
        The members' control mode (default the scenario's; ``commanded``: driven by the
        fill-flow and purge readings, docs/theory/estimation.md#ensemble).
    """

    def __init__(self, scenario, sensors, members: int = 24, seed: int = 0,
                 prior: Prior | None = None, control: str | None = None, plant=None):
        self.ensemble = Ensemble(scenario, members, seed, prior, control, plant)
        self.sensors = sensors
        self.names = self.ensemble.plant.names
        run = self.ensemble.runs[0]
        self.valves = ({self.names[i]: j for j, i in enumerate(run.controllers.bags)}
                       if control == COMMANDED else {})
        self.by_name = {s.name: k for k, s in enumerate(sensors)}
        rho_g = float(run.records.bags.rho_g)
        for s in sensors:  # resampling leaves at least the gas a load cell cannot tell
            if s.quantity == "sling_force" and s.bag in self.names:
                self.ensemble.gas_floor_m3[self.names.index(s.bag)] = max(
                    s.noise, NOISE_FLOOR["sling_force"]) / rho_g
        self.counts = Counts()
        self.rng = np.random.default_rng(seed + 1)
        #: the valves' inaccuracy taken as process noise [-] (:attr:`Prior.valve`)
        self.valve_spread = self.ensemble.prior.valve
        self.t = 0.0  # the time the members stand at [s]
        #: the last window's members had lost the lift (most of them off the motion readings,
        #: or widened): its predictions are not a fault detector's yardstick
        self.lost = False
        self._row = self._row_before = 0  # the first recorded row not yet read
        #: when the readings said the lift separated, (after, at or before) [s]; None: not yet
        self.separated: tuple[float, float] | None = None

    def assimilate(self, t_end: float, readings) -> list[Prediction]:
        """Advance the members to ``t_end`` [s] and update them with ``readings``
        (:class:`flexlift.sensors.log.Reading`, each with ``t_end - window < time_s <=
        t_end``); returns each reading's prediction."""
        ens = self.ensemble
        ens.advance(int(round(t_end / ens.dt)) + 1)
        t_before, self.t = self.t, t_end
        readings = [r for r in readings if r.sensor in self.by_name]
        if not readings:
            ens.valve_noise(self.valve_spread, self.rng)
            return []
        Y = self._predicted(readings)
        noise = np.array([self.sensors[self.by_name[r.sensor]].noise for r in readings])
        z = np.array([r.value for r in readings])
        mean, spread = Y.mean(axis=1), Y.std(axis=1, ddof=1)
        std = np.sqrt(spread**2 + noise**2)
        quantity = [self.sensors[self.by_name[r.sensor]].quantity for r in readings]
        observed = np.array([q in OBSERVED for q in quantity])
        floor = np.array([NOISE_FLOOR.get(q, 0.0) for q in quantity])
        sigma = np.maximum(noise, floor)
        motion = observed & np.array([q != "sling_force" for q in quantity])
        self.lost = False
        release = None  # the lift separated while members are held: when [s]
        # the members' own valves' feedback weighs them too (commanded members' valves are
        # the commands, alike in every member: nothing to weigh)
        # (a bag with no dump valve has no opening to predict: NaN, nothing to weigh)
        # (after the separation too: weighed only while a member was held, the members'
        # dump valves cycled out of step with the lift's and two benchmark lifts of four
        # were lost for hundreds of windows, one to false ruptures; docs/theory/estimation.md#clock)
        feedback = (np.array([q in FEEDBACK for q in quantity]) & (not self.valves)
                    & np.isfinite(Y).all(axis=1))
        if motion.any() or feedback.any():  # the members that explain the readings
            r = (z[motion, None] - Y[motion]) / sigma[motion, None]
            worst = (np.mean(r**2, axis=0) > OUTLIER**2 if motion.any()
                     else np.zeros(self.ensemble.m, dtype=bool))
            self.lost = bool(worst.mean() > LOST_SHARE)
            log_w = -0.5 * np.minimum(r**2, GATE**2).sum(axis=0)
            f = (z[feedback, None] - Y[feedback]) / sigma[feedback, None]
            log_w = log_w - 0.5 * np.minimum(f**2, GATE**2).sum(axis=0)
            depth = np.array([q == "depth" for q in quantity])
            dump = feedback[feedback] & np.array([q == "purge" for q in quantity])[feedback]
            if self._separated_first(f[dump], worst, z[depth, None] - Y[depth]):
                # the lift separates once: members still held after a release (their
                # uplift fell below their hold again within the window) are given the
                # first release's interval, not a later one
                release = self.separated or self._separated_in(readings, z, Y, sigma,
                                                               feedback, (t_before, t_end))
                self.separated = release
            if self.ensemble.resample(log_w, self.rng,
                                      force=bool(worst.any() and not worst.all())):
                self.counts.resampled += 1
                Y = self._predicted(readings, again=True)
        used = gated(Y, z, sigma, observed)
        if np.sum(motion & ~used) > 0.5 * np.sum(motion):  # every member has lost the lift
            Y = self._widen(Y, z, sigma, motion)
            used = observed
            self.lost = True
        self.counts.lost_windows += self.lost
        self._count(readings, observed, used)
        if used.any():
            self._update(readings, quantity, Y, z, sigma, used)
            self.counts.updates += 1
        self._command(readings, quantity)
        ens.valve_noise(self.valve_spread, self.rng)  # the window to come's process noise
        if release is not None and any(not run.state.sep.any() for run in ens.runs):
            ens.release(release, self.rng)  # last: no change of the gas after it undoes it
            self.counts.released += 1
        return [Prediction(r.time_s, r.sensor, r.value, float(mean[k]), float(std[k]),
                           bool(used[k])) for k, r in enumerate(readings)]

    def _separated_first(self, f: np.ndarray, lost: np.ndarray, rise: np.ndarray) -> bool:
        """Whether the lift has separated while members are still held
        (docs/theory/estimation.md#hold). Either its dump valves opened where no held
        member's did (the members' controllers open them at separation, as the lift's did):
        each held member's normalised dump-valve innovations ``f`` (readings, members) off by
        more than :data:`OUTLIER` in root mean square, the readings above the predictions;
        or, without dump-valve feedback, every member has ``lost`` the lift's motion and
        every held member's depth innovations ``rise`` [m] (readings, members) say the lift
        is above it (a depth less than predicted). Members already separated do not count:
        the lift has separated whether or not one of them did with it. (The motion's test
        stands also where the dump valves say nothing: a lift whose controller does not
        purge at separation.)"""
        held = np.array([not run.state.sep.any() for run in self.ensemble.runs])
        if not held.any():
            return False
        if f.size:
            f = f[:, held]
            if np.all(np.mean(f**2, axis=0) > OUTLIER**2) and np.all(f.mean(axis=0) > 0):
                return True
        return bool(lost.all() and rise.size and np.all(rise[:, held].mean(axis=0) < 0))

    def _separated_in(self, readings, z, Y, sigma, feedback, window) -> tuple[float, float]:
        """When the lift separated, as the readings bound it [s]: after the last reading of a
        dump valve still shut and at or before the first of one opened (more than
        :data:`OUTLIER` predicted standard deviations above the members' mean: the valves
        open at separation), i.e. within one period of that valve's sensor before its first
        open reading; without such a reading, within the window (docs/theory/estimation.md#clock)."""
        k = np.flatnonzero(feedback)
        opened = k[(z[k] - Y[k].mean(axis=1)) / sigma[k] > OUTLIER]
        if not opened.size:
            return window
        first = min(opened, key=lambda j: readings[j].time_s)
        t1 = readings[first].time_s
        return t1 - self.sensors[self.by_name[readings[first].sensor]].period_s, t1

    def _widen(self, Y, z, sigma, motion) -> np.ndarray:
        """The members' motion spread widened to cover the readings when more than half of
        them fail the gate (the whole ensemble off the lift: a separation earlier or later
        than every member's). The anomalies of the modal coordinates and rates, and of the
        predicted readings, are scaled by the root mean square of the normalised innovations
        (adaptive inflation, at most :data:`WIDEN_MAX`); then every reading is assimilated.
        Returns the predicted readings so widened."""
        ens = self.ensemble
        mean = Y.mean(axis=1, keepdims=True)
        spread = Y.std(axis=1, ddof=1, keepdims=True)[:, 0]
        ratio = (z - mean[:, 0])[motion] / np.sqrt(spread[motion] ** 2 + sigma[motion] ** 2)
        factor = min(max(float(np.sqrt(np.mean(ratio**2))), 1.0), WIDEN_MAX)
        X = ens.columns()
        rows = slice(0, ens.sizes["q"] + ens.sizes["v"])
        centre = X[rows].mean(axis=1, keepdims=True)
        X[rows] = centre + factor * (X[rows] - centre)
        ens.write(X)
        self.counts.widened += 1
        return mean + factor * (Y - mean)

    def _update(self, readings, quantity, Y, z, sigma, used) -> None:
        """The ETKF by groups of readings (serial: their noises are independent), each
        group on the rows it may move (domain localisation, docs/theory/estimation.md#local):
        a bag's load cell its own gas and leak; the depths and inclinometers the motion (the
        weight and the holding force are left to resampling: their effect on the readings is
        a threshold, separation, not a line; so is the clock, whose effect on a window's
        readings is a fraction of a gauge's noise). The groups' rows are disjoint, so each group's
        update leaves the others' predicted readings as they were."""
        ens = self.ensemble
        X = ens.columns()
        before = X.copy()
        for rows, members in self._groups(readings, quantity, used):  # disjoint rows
            X[rows] = analysis(X[rows], Y[members], z[members], np.diag(sigma[members] ** 2))
        after = relaxed(before, X)
        if not np.all(np.isfinite(after)):  # a member blown up: no update this window
            self.counts.rejected += 1
            return
        ens.write(after)

    def _groups(self, readings, quantity, used) -> list[tuple[np.ndarray, np.ndarray]]:
        """(rows of the members' columns, readings) per group of the update."""
        ens, index = self.ensemble, {name: j for j, name in enumerate(self.names)}
        offset, k = {}, 0
        for name in PARTS:
            offset[name] = k
            k += ens.sizes[name]
        groups, broad = [], []
        by_bag: dict[int, list[int]] = {}
        for j in np.flatnonzero(used):
            if quantity[j] == "sling_force":
                bag = self.sensors[self.by_name[readings[j].sensor]].bag
                by_bag.setdefault(index[bag], []).append(int(j))
            else:
                broad.append(int(j))
        for b, members in by_bag.items():
            groups.append((np.array([offset["n"] + b, offset["leak"] + b]), np.array(members)))
        if broad:  # the motion; the weight, the hold and the clock by resampling only
            groups.append((np.arange(offset["n"]), np.array(broad)))
        return groups

    def _command(self, readings, quantity) -> None:
        """Commanded members: every bag's valves set to its latest fill-flow (read as free air,
        commanded at the member's bag pressure, Boyle) and purge [-] readings, held to the
        next window."""
        if not self.valves:
            return
        latest: dict[tuple[str, str], tuple[float, float]] = {}
        for r, q in zip(readings, quantity):
            if q in ("fill_flow", "purge"):
                key = (self.sensors[self.by_name[r.sensor]].bag, q)
                if key not in latest or r.time_s >= latest[key][0]:
                    latest[key] = (r.time_s, r.value)
        for (bag, q), (_, value) in latest.items():
            self.command(bag, "fill" if q == "fill_flow" else "purge", value)

    def command(self, bag: str, valve: str, value: float, free_air: bool = True,
                delay_s: float = 0.0) -> None:
        """Commanded members: ``bag``'s ``valve`` set on every member from now on: ``fill``
        [m^3/s: of free air (a flow meter's reading), commanded at the member's bag
        pressure, Boyle; or, ``free_air`` False, at the bag's pressure already (a command
        as sent); each member's times its own draw of :data:`FILL_SPREAD`] or ``purge``
        opening [-]. A bag not controlled, or members not commanded, take nothing.

        ``delay_s`` [s]: the command reaches the valve some time within this after it was
        sent (its travel, the valve's next cycle). Each member draws its own delay d, uniform
        in [0, ``delay_s``], and its gas is given what the old setting would have moved in d:
        d p (Q_old - Q_new) / (R T), the flows at the bag's pressure (the timing's process
        noise: the members part as the lift's own timing is unknown)."""
        j = self.valves.get(bag)
        if j is None:
            return
        i = self.names.index(bag)
        m = self.ensemble.m
        spread = np.maximum(1.0 + FILL_SPREAD * self.rng.standard_normal(m), 0.0)
        late = self.rng.uniform(0.0, delay_s, m) if delay_s > 0 else np.zeros(m)
        for k, run in enumerate(self.ensemble.runs):
            before = _flow(run, i, j)
            if valve == "fill":
                scale = run.records.bags.p_atm / run.state.p[i] if free_air else 1.0
                run.command(j, fill=max(value, 0.0) * scale * spread[k])
            else:
                run.command(j, opening=value)
            if late[k] > 0.0:
                dn = late[k] * moles_rate(run.state.p[i], before - _flow(run, i, j), 0.0,
                                          run.records.bags.RT)
                run.state.n[i] = max(run.state.n[i] + dn, 0.0)

    def _count(self, readings, observed, used) -> None:
        c = self.counts
        c.assimilated += int(used.sum())
        c.not_observed += int((~observed).sum())
        for k in np.flatnonzero(observed & ~used):
            c.gated += 1
            c.by_sensor_gated[readings[k].sensor] = c.by_sensor_gated.get(
                readings[k].sensor, 0) + 1

    def _predicted(self, readings, again: bool = False) -> np.ndarray:
        """(p, m): each member's value of each reading, its rows interpolated at the
        reading's time (``again``: the same window's once more, after resampling)."""
        ens, times = self.ensemble, np.array([r.time_s for r in readings])
        wanted = sorted({self.by_name[r.sensor] for r in readings})
        sensors = [self.sensors[k] for k in wanted]
        of = np.array([wanted.index(self.by_name[r.sensor]) for r in readings])
        columns = [(j, np.flatnonzero(of == j)) for j in range(len(wanted))]
        Y = np.empty((len(readings), ens.m))
        for i, run in enumerate(ens.runs):
            rec = run.recorder
            r1 = int(rec.counts[0])
            first = self._row_before if again else self._row
            r0 = max(min(first, r1 - 1) - 1, 0)  # the row before the window as well
            values = true_values(sensors, self.names, run.clusters.of_bag, run.records.bags,
                                 rec, r0, r1, run.switches.supply)
            t = rec.t[r0:r1]
            for j, rows in columns:
                Y[rows, i] = np.interp(times[rows], t, values[:, j])
        if not again:
            self._row_before, self._row = self._row, int(ens.runs[0].recorder.counts[0])
        return Y

    def state(self) -> dict[str, np.ndarray]:
        """The members' mean and 5 / 95 % of what a user reads, now: per bag ``height`` [m]
        and ``gas_volume`` [m^3], the hull's ``heave`` [m] and ``pitch`` [rad], the
        ``holding_force`` [N], the ``weight_factor`` [-] and each bag's ``leak`` [1/s]."""
        ens = self.ensemble
        rows = {name: [] for name in ("height", "gas_volume", "heave", "pitch",
                                      "holding_force")}
        for run in ens.runs:
            rec, r = run.recorder, int(run.recorder.counts[0]) - 1
            for name in ("height", "gas_volume"):
                rows[name].append(rec.bag[r, _BAG[name], :])
            for name in ("heave", "pitch", "holding_force"):
                rows[name].append(rec.hull[r, _HULL[name]:_HULL[name] + 1])
        rows["weight_factor"] = [np.array([w]) for w in ens.weight]
        rows["leak"] = [run.switches.leak.copy() for run in ens.runs]
        return {name: np.percentile(np.array(v), [5, 50, 95], axis=0)
                for name, v in rows.items()}


def _flow(run, i: int, j: int) -> float:
    """Bag ``i``'s net gas flow into it [m^3/s at its pressure] from its valves as set
    (controlled bag ``j``): the fill (if supplied) less the purge."""
    cs, bags = run.control_state, run.records.bags
    fill = float(cs.fill[j]) * float(run.switches.supply[i])
    opening = float(cs.opening[j])
    purge = (purge_flow(opening, float(run.state.V[i]), float(bags.capacity[i]),
                        float(bags.purge_max[i])) if opening > 0.0 else 0.0)
    return fill - purge


def gated(Y, z, sigma, observed) -> np.ndarray:
    """The observed readings within :data:`GATE` standard deviations (the members' spread
    with the reading's noise) of the members' mean."""
    spread = Y.std(axis=1, ddof=1)
    return observed & (np.abs(z - Y.mean(axis=1)) <= GATE * np.sqrt(spread**2 + sigma**2))


def relaxed(before: np.ndarray, after: np.ndarray, alpha: float = RELAXATION) -> np.ndarray:
    """The members ``after`` the update, their anomalies relaxed to those ``before`` it
    (RTPP): ``mean_a + (1 - alpha) A_a + alpha A_b``."""
    mean = after.mean(axis=1, keepdims=True)
    A_b = before - before.mean(axis=1, keepdims=True)
    return mean + (1.0 - alpha) * (after - mean) + alpha * A_b


def window_steps(scenario, window_s: float | None) -> float:
    """The assimilation window [s]: a whole number of the loop's recorded rows, at least one
    (default: the fastest assimilated sensor's period, at least a row)."""
    row = scenario.simulation.output_interval_s
    w = row if window_s is None else max(window_s, row)
    return row * max(1, math.floor(w / row + 1e-9))
