"""The estimator's ensemble: members that are runs of the compiled loop on one plant
(docs/theory/estimation.md#ensemble).

Each member is an :class:`~flexlift.ascent.loop.Ascent` of the scenario on the one plant
built for all of them (``prepare(..., plant=plant)``); the members differ only in what is
unknown: the submerged weight (a factor on the plant's wet-weight records, which each member
holds its own copy of), the holding force left (``state.H``), each bag's gas
(``state.n``), each bag's leak rate (``switches.leak``, [1/s]: a ruptured bag's escape) and,
once separated, when the lift separated (the member's clock: its controllers' reference and
the seabed's release start there; docs/theory/estimation.md#clock).
All members advance together, one compiled call per chunk
(:func:`flexlift.ascent.batch.advance_batch`). Their state is read into and written from
columns of named parts (:data:`PARTS`) for the filter's update.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from filterpy.monte_carlo import systematic_resample
from scipy.stats import truncnorm

from flexlift.ascent import kernel
from flexlift.ascent.batch import advance_batch
from flexlift.ascent.loop import Ascent, prepare
from flexlift.ascent.plant import coupled_plant

#: the parts of a member's column, in order: the loop's state fields (modal coordinates and
#: rates, gas [mol], holding force [N]), the leak rates [1/s], the weight factor [-] and the
#: clock: the shift of the member's separation time from when it separated by itself [s]
PARTS = ("q", "v", "n", "H", "leak", "weight", "clock")


@dataclass(frozen=True)
class Prior:
    """What is not known before the lift, as standard deviations about the scenario's
    values (assumed; docs/theory/estimation.md#prior): ``weight`` (only 0 for now: see
    :class:`Ensemble`) and ``holding`` relative [-], ``gas`` relative per bag [-], ``leak`` per bag [1/s] (a half-normal: no bag leaks
    gas in, a leak never goes below 0); and, during the lift, ``valve``: each valve's flow
    off by this fraction of what it moved in a control period [-], drawn afresh each period
    (the process noise of :func:`valve_noise`; 0: none)."""

    weight: float = 0.0
    holding: float = 0.25
    gas: float = 0.02
    leak: float = 1.0e-5
    valve: float = 0.02


class Ensemble:
    """``members`` runs of ``scenario`` under its own control mode (or ``control``) on one
    plant, their unknowns drawn from ``prior`` with ``seed``.

    Parameters
    ----------
    scenario : Scenario
    members : int
    seed : int
    prior : Prior
    control : str, optional
        The members' control mode (default the scenario's).
    plant : Plant, optional
        Built from the scenario when not given.
    """

    def __init__(self, scenario, members: int = 24, seed: int = 0,
                 prior: Prior | None = None, control: str | None = None, plant=None):
        if members < 2:
            raise ValueError(f"an ensemble needs at least 2 members, not {members}")
        if prior is not None and prior.weight != 0.0:
            # the strength recovery (ascent/strength.py) reads the plant's own wet weight: a
            # member's factor on the loop's records alone leaves its load case open (on the
            # pipeline, M of several MN m at the free end): not until both take it
            raise ValueError(f"the submerged weight as an unknown (Prior.weight = "
                             f"{prior.weight}) is not supported yet: use 0")
        if scenario.faults:  # the members are the lift as planned: finding faults is the
            scenario = scenario.with_changes(faults=[])  # detector's, not the members' script
        self.scenario = scenario
        self.prior = prior or Prior()
        self.plant = plant if plant is not None else coupled_plant(scenario)
        length = float(scenario.simulation.run_length_s)
        self.runs: list[Ascent] = [prepare(scenario, control, length, plant=self.plant,
                                           share=False) for _ in range(members)]
        base = self.runs[0].records
        self._base = (base.modal.weight_force.copy(), base.bags.corr_weight.copy(),
                      base.bags.slope_weight.copy(), base.seabed.group_weight.copy())
        for run in self.runs:
            run.records = _own_weight(run.records)
        self.weight = np.ones(members)
        #: each member's clock [s]: how far its separation's times (its controllers' and the
        #: seabed's) have been moved from when it separated by itself (:meth:`release`)
        self.clock = np.zeros(members)
        #: the separation time [s] each released member is to be given once it has separated
        #: (:meth:`settle`); NaN: none pending
        self._pending = np.full(members, np.nan)
        #: each member's holding force as drawn at the start [N] (m, ng): its hold now less
        #: this is the decay so far, which the timer law makes the same for any start
        self.hold_start = np.zeros((members, self.plant.seabed.H0.size))
        self._draw(np.random.default_rng(seed))
        for run in self.runs:
            run.start()
        self.ended = [False] * members
        run = self.runs[0]
        self.sizes = {"q": run.state.q.size, "v": run.state.v.size, "n": run.state.n.size,
                      "H": run.state.H.size, "leak": run.switches.leak.size, "weight": 1,
                      "clock": 1}
        #: each bag's least spread of gas that resampling leaves [m^3 at the bag's pressure]
        #: (the estimator sets it: what one load-cell reading cannot tell apart); 0: none
        self.gas_floor_m3 = np.zeros(run.state.n.size)
        #: each member's valves' flows so far at the last :meth:`valve_noise` [m^3 at the
        #: bag's pressure] (m, nb): filled, purged
        self._flows = accounts(self.runs)

    @property
    def m(self) -> int:
        return len(self.runs)

    @property
    def dt(self) -> float:
        return self.runs[0].settings.dt

    @property
    def step(self) -> int:
        """The step the members stand at (all alike)."""
        return int(self.runs[0].state.counters[0])

    def _draw(self, rng: np.random.Generator) -> None:
        p, H0 = self.prior, self.plant.seabed.H0
        for i, run in enumerate(self.runs):
            self.weight[i] = 1.0 + p.weight * rng.standard_normal()
            run.state.H[:] = H0 * max(1.0 + p.holding * rng.standard_normal(), 0.0)
            self.hold_start[i] = run.state.H
            run.state.n[:] *= 1.0 + p.gas * rng.standard_normal(run.state.n.size)
            run.switches.leak[:] = np.abs(p.leak * rng.standard_normal(run.switches.leak.size))
            self._set_weight(i)
            kernel.initial_equilibrium(run.inputs())  # at rest under their own loads

    def _set_weight(self, i: int) -> None:
        records, f = self.runs[i].records, self.weight[i]
        wf, cw, sw, gw = self._base
        records.modal.weight_force[:] = wf * f
        records.bags.corr_weight[:] = cw * f
        records.bags.slope_weight[:] = sw * f
        records.seabed.group_weight[:] = gw * f

    def advance(self, until: int) -> None:
        """Every member to step ``until`` (exclusive) together."""
        self.ended = advance_batch(self.runs, until, self.ended)
        self.settle()

    def valve_noise(self, spread: float, rng: np.random.Generator) -> None:
        """Every member's gas moved by its valves' own inaccuracy since the last call
        (:func:`valve_noise`)."""
        self._flows = valve_noise(self.runs, self._flows, spread, rng)

    def columns(self) -> np.ndarray:
        """The members' columns (n, m) in the order of :data:`PARTS`."""
        return np.column_stack([np.concatenate([
            run.state.q, run.state.v, run.state.n, run.state.H, run.switches.leak,
            [self.weight[i]], [self.clock[i]]]) for i, run in enumerate(self.runs)])

    def write(self, X: np.ndarray) -> None:
        """The members set from columns ``X`` (after the filter's update): gas, holding force
        and leak kept at or above 0, the weight factor above 0; a held block ended."""
        for i, run in enumerate(self.runs):
            parts = self.split(X[:, i])
            run.state.q[:] = parts["q"]
            run.state.v[:] = parts["v"]
            run.state.n[:] = np.maximum(parts["n"], 0.0)
            run.state.H[:] = np.where(run.state.sep, run.state.H, np.maximum(parts["H"], 0.0))
            run.switches.leak[:] = np.maximum(parts["leak"], 0.0)
            self.weight[i] = max(float(parts["weight"][0]), 0.05)
            self._set_weight(i)
            # (the update leaves the clock, RTPP within rounding: only a real move moves it)
            delta = float(parts["clock"][0]) - self.clock[i]
            if abs(delta) > 1e-9:
                self._shift(i, delta)
            run.end_held_block()

    def resample(self, log_weights: np.ndarray, rng: np.random.Generator,
                 force: bool = False, discount: float = 0.98) -> bool:
        """Resample the members by their readings' likelihoods (``log_weights``) when the
        effective ensemble size falls below half the members, or when ``force``d (filterpy's
        systematic resampling); a member drawn twice runs on as a fork
        (:meth:`~flexlift.ascent.loop.Ascent.fork`). The weight factor and each bag's gas
        are then drawn from Liu and West's (2001) kernel: each shrunk towards the weighted
        mean by ``a`` and spread by ``sqrt(1 - a^2)`` times the weighted standard deviation,
        ``a = (3 d - 1) / (2 d)`` for the ``discount`` d: their mean and spread are kept, so
        resampling does not collapse them, and the copies part. The holding force of a group
        still held is drawn afresh from its prior truncated at the group's uplift now
        (:meth:`held_draw`: all a held lift's readings say of its hold is that it is
        above the uplift). Returns whether it resampled."""
        # a member whose predictions are not numbers (its run blown up) is the least likely
        log_weights = np.where(np.isfinite(log_weights), log_weights, -np.inf)
        if not np.isfinite(log_weights).any():
            return False  # no member to weigh the others by: nothing resampled
        w = np.exp(log_weights - log_weights.max())
        w /= w.sum()
        if 1.0 / np.sum(w**2) >= self.m / 2 and not force:
            return False
        shrink = (3.0 * discount - 1.0) / (2.0 * discount)
        spread = math.sqrt(1.0 - shrink**2)
        n = np.array([run.state.n for run in self.runs])  # (m, nb)
        kernels = {"weight": _kernel(self.weight, w), "n": _kernel(n, w),
                   "clock": _kernel(self.clock, w)}
        # weights on one member leave no spread to draw from: never less than the members'
        # own spread before (unweighted), up to the gas a load cell cannot tell apart
        # (gas_floor_m3, as moles at the members' mean pressure): the members keep what
        # spread they had, and a floor of one reading's resolution does not widen a bag
        # the readings have pinned closer (small bags: the Grieg barge's 5 kN cells)
        p = np.mean([run.state.p for run in self.runs], axis=0)
        floor = np.minimum(self.gas_floor_m3 * p / self.runs[0].records.bags.RT,
                           n.std(axis=0, ddof=1)) / spread
        kernels["n"] = (kernels["n"][0], np.maximum(kernels["n"][1], floor))
        # (filterpy walks its cumulative sum past the end when rounding leaves it just
        # below 1: the weights are given a sum a hair above 1)
        chosen = _systematic(w * (1.0 + 1e-12), rng)
        seen: set[int] = set()
        runs, weight, ended = [], np.empty(self.m), []
        clock, pending = np.empty(self.m), self._pending[chosen.astype(int)]
        moved: dict[int, float] = {}  # each parent's clock once its own slot has moved it
        # each parent's decay of its hold so far, before any slot's draw moves its hold
        decay = self.hold_start - np.array([run.state.H for run in self.runs])
        hold_start = np.empty_like(self.hold_start)
        for slot, j in enumerate(chosen):
            j = int(j)
            run = self.runs[j].fork() if j in seen else self.runs[j]
            if j in seen:
                run.records = _own_weight(run.records)
            seen.add(j)
            mean, sd = kernels["weight"]
            weight[slot] = max(shrink * self.weight[j] + (1.0 - shrink) * mean
                               + spread * sd * rng.standard_normal(), 0.05)
            hold_start[slot] = self.held_draw(run, decay[j], rng)
            mean, sd = kernels["clock"]  # a separated member's clock parts as its gas does
            clock[slot] = self.clock[j]
            if separated(run):
                clock[slot] = shrink * self.clock[j] + (1.0 - shrink) * mean \
                    + spread * sd * rng.standard_normal()
                # a fork copies its parent as it stands now: moved already, if drawn before
                shift_clock(run, clock[slot] - moved.get(j, self.clock[j]))
                moved.setdefault(j, clock[slot])
            mean, sd = kernels["n"]
            run.state.n[:] = np.maximum(shrink * n[j] + (1.0 - shrink) * mean
                                        + spread * sd * rng.standard_normal(n.shape[1]), 0.0)
            run.end_held_block()
            runs.append(run)
            ended.append(self.ended[j])
        self.runs, self.weight, self.ended, self.hold_start = runs, weight, ended, hold_start
        self.clock, self._pending = clock, pending
        self._flows = accounts(self.runs)
        for i in range(self.m):
            self._set_weight(i)
        return True

    def held_draw(self, run: Ascent, decay: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """``run``'s holding force of each group still held drawn afresh from the prior
        truncated below at the group's uplift now (docs/theory/estimation.md#hold); returns
        the holding forces at the start [N] that this draw stands for (the hold now plus
        ``decay``).

        ``decay`` [N] is the run's decay of its hold so far: its start less its hold now.
        Under the timer law (dH/dt = -min(U, H_0) / T_b) the decay does not depend on the
        start, so the prior of the hold now is the prior of the start shifted by it: a
        normal of mean ``H_0 - decay`` and standard deviation ``holding H_0``. Under the
        soil law the decay depends on the hold itself and the shift is an approximation. A
        group whose uplift is not positive is not separating: its lower bound is 0."""
        H, H0 = run.state.H, self.plant.seabed.H0
        for g in np.flatnonzero(~run.state.sep):
            mean, sd = H0[g] - decay[g], self.prior.holding * H0[g]
            low = max(_uplift(run, g), 0.0)
            if sd <= 0.0:
                continue
            a = (low - mean) / sd
            if a > 8.0:  # the prior has no mass above the uplift: the least hold that holds
                H[g] = low
            else:
                H[g] = float(truncnorm.rvs(a, np.inf, loc=mean, scale=sd, random_state=rng))
        return H + decay

    def release(self, between: tuple[float, float] | None = None,
                rng: np.random.Generator | None = None) -> None:
        """Every member's held groups set to separate at their next step: the hold just below
        the group's uplift (docs/theory/estimation.md#hold: the lift has separated, so its hold
        is below its uplift now; held until now, it was above it a window ago). A group whose
        uplift is not positive is left held. (Called last in a window: an update of the gas
        after it, or the valves' noise, could take the uplift back below the hold.)

        ``between`` (t0, t1) [s]: the readings say the lift separated in (t0, t1]
        (docs/theory/estimation.md#clock); each member is to have separated at its own draw,
        uniform over it (``rng``), set once it has separated (:meth:`settle`): the members
        released together would all separate at one moment, later than the lift, and their
        controllers' references, started there, would bring every one of them to the surface
        that much late, a forecast of no spread and off."""
        if between is not None:  # the members still held
            t0, t1 = between
            held = np.array([not run.state.sep.any() for run in self.runs])
            self._pending[held] = rng.uniform(t0, t1, int(held.sum())) if t1 > t0 else t1
        for i, run in enumerate(self.runs):
            for g in np.flatnonzero(~run.state.sep):
                uplift = _uplift(run, g)
                if 0.0 < uplift < run.state.H[g]:
                    below = uplift * (1.0 - 1e-9)
                    self.hold_start[i, g] += below - run.state.H[g]
                    run.state.H[g] = below
            run.end_held_block()

    def settle(self) -> None:
        """Each released member that has separated since given the separation time drawn for
        it (:meth:`release`): its clock moved by that time less its own."""
        for i in np.flatnonzero(np.isfinite(self._pending)):
            own = separation_time(self.runs[i])
            if math.isfinite(own):
                self._shift(i, float(self._pending[i]) - own)
                self._pending[i] = math.nan

    def _shift(self, i: int, delta: float) -> None:
        """Member ``i``'s clock moved by ``delta`` [s] (nothing before it has separated)."""
        if delta != 0.0 and separated(self.runs[i]):
            shift_clock(self.runs[i], delta)
            self.clock[i] += delta

    def split(self, column: np.ndarray) -> dict[str, np.ndarray]:
        """A column's parts by name."""
        out, k = {}, 0
        for name in PARTS:
            out[name] = column[k:k + self.sizes[name]]
            k += self.sizes[name]
        return out


def accounts(runs: list[Ascent]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each run's valves' flows so far [m^3 at its bags' pressure] (m, nb), filled and
    purged, and its step (m,): what :func:`valve_noise` measures the next flows from."""
    return (np.array([run.state.gas_local for run in runs]),
            np.array([run.state.purged for run in runs]),
            np.array([int(run.state.counters[0]) for run in runs]))


def valve_noise(runs: list[Ascent], since, spread: float, rng: np.random.Generator):
    """Each run's gas moved by its valves' own inaccuracy since ``since`` (its
    :func:`accounts` then): process noise (docs/theory/estimation.md#process-noise). A valve
    is off by a fraction ``spread`` [-] of what it moved in each control period, drawn
    afresh each period, so over an interval of K periods in which a bag's fill and purge moved
    dV_fill and dV_purge the gas moves by spread p / (R T) sqrt((dV_fill^2 + dV_purge^2) / K)
    e, e ~ N(0, 1), drawn per run and bag (a bag whose valves were shut is not moved; the
    same variance whatever the interval). Returns the accounts now, for the next call."""
    now = accounts(runs)
    dV = np.hypot(now[0] - since[0], now[1] - since[1])  # (m, nb)
    for i, run in enumerate(runs):
        periods = (now[2][i] - since[2][i]) / run.settings.k_ctrl
        if not dV[i].any() or periods <= 0.0:
            continue
        dn = spread * run.state.p * dV[i] / (run.records.bags.RT * math.sqrt(max(periods, 1.0)))
        run.state.n[:] = np.maximum(run.state.n + dn * rng.standard_normal(dn.size), 0.0)
        run.end_held_block()
    return now


def separated(run: Ascent) -> bool:
    """Whether any of ``run``'s controllers has noted a separation."""
    return bool(np.isfinite(run.control_state.t_sep).any())


def separation_time(run: Ascent) -> float:
    """The first separation ``run``'s controllers noted [s] (NaN: none yet)."""
    t = run.control_state.t_sep
    return float(np.nanmin(t)) if np.isfinite(t).any() else math.nan


def shift_clock(run: Ascent, delta: float) -> None:
    """``run``'s separation moved by ``delta`` [s]: the times its controllers noted their
    holds let go and started their references (``t_free``, ``t_sep``), and the times its
    groups separated, from which the seabed's release runs (``state.release[0]``). Its state
    now is not moved (a shift of seconds at the start of an ascent moves the lift by
    millimetres): what moves is what is still to come, on the reference's time line."""
    cs = run.control_state
    for a in (cs.t_free, cs.t_sep, run.state.release[0]):
        a[np.isfinite(a)] += delta
    run.end_held_block()


def _uplift(run: Ascent, g: int) -> float:
    """Holding group ``g``'s net uplift in ``run`` now [N]: its bags' buoyancy less its wet
    weight (the member's own), as the loop's ``group_uplift`` reckons it."""
    bags, attached, on = run.records.bags, run.switches.attached, run.records.bags.group == g
    return float(bags.rho_g * np.sum(run.state.V[on] * attached[on] * bags.count[on])
                 - run.records.seabed.group_weight[g])


def _own_weight(records):
    """The plant's records with the wet weight's arrays a member's own (copied)."""
    modal, bags, seabed = records.modal, records.bags, records.seabed
    return records._replace(
        modal=modal._replace(weight_force=modal.weight_force.copy()),
        bags=bags._replace(corr_weight=bags.corr_weight.copy(),
                           slope_weight=bags.slope_weight.copy()),
        seabed=seabed._replace(group_weight=seabed.group_weight.copy()))


def _kernel(values: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The weighted mean and standard deviation over the members (axis 0) of ``values``."""
    mean = np.tensordot(w, values, axes=1)
    var = np.tensordot(w, (values - mean) ** 2, axes=1)
    return mean, np.sqrt(var)


def _systematic(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """filterpy's ``systematic_resample`` of ``weights``, its one random offset drawn from
    ``rng``: filterpy draws it from numpy's global generator, which nobody seeds, so the same
    seed gave other replays (the pull's members parted by 1,500 s). The global generator's
    state is set from ``rng`` for the call and given back as it was after it."""
    saved = np.random.get_state()  # noqa: NPY002 - filterpy reads the global one
    np.random.seed(int(rng.integers(2**32)))  # noqa: NPY002
    try:
        return systematic_resample(weights)
    finally:
        np.random.set_state(saved)  # noqa: NPY002
