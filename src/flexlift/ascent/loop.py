"""``simulate``: the ascent of a scenario, for any plant and control mode
(docs/theory/loop.md#integration).

The compiled loop (:mod:`flexlift.ascent.kernel`) runs in chunks; between chunks this module
applies the faults due, draws the next chunk of noise, evaluates an external supervisor when
one is used, and reports progress. The run stops when every bag point has held within
``limits.arrival_tolerance_m`` of the target for ``simulation.hold_time_s``, when a bag
breaches the surface (one of the paper's bags; a bag with a surface law goes on until the
structure resettles: docs/theory/gas.md#surface), at ``simulation.duration_s`` (``auto``: the
longest run the scenario's limits allow, the record grown as it goes), or with
:class:`~flexlift.errors.SimulationError` (its ``partial`` the result so far) when the
numerics fail.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from flexlift.ascent import kernel
from flexlift.ascent.checks import planned_run, refuse_unworkable, warn_short
from flexlift.ascent.clusters import (
    expand,
    expand_events,
    find_clusters,
    loop_controllers,
    loop_records,
)
from flexlift.ascent.faults import apply_fault, check_faults, fault_step
from flexlift.ascent.noise import ForceNoise, MeasurementNoise
from flexlift.ascent.paper import paper_plant
from flexlift.ascent.plant import Plant, check_neutral, coupled_plant
from flexlift.ascent.records import LoopInputs
from flexlift.ascent.result import HULL_VARS, Result, build_result
from flexlift.ascent.state import (
    EV_NUMERICS,
    F_HAVE_B,
    F_HELD,
    F_QUIET,
    F_STILL,
    RET_NEED_U,
    RET_STOP,
    Settings,
    new_record,
    new_run_state,
    new_switches,
)
from flexlift.control.build import controller_for, fuzzy_maps
from flexlift.control.controller import new_state
from flexlift.errors import InputError, SimulationError
from flexlift.physics.seabed import released_holding

MODES = ("decentralized", "coordinated", "paper", "open-loop", "commanded")
#: the mode whose valves are commanded from outside between chunks (:meth:`Ascent.command`)
COMMANDED = "commanded"
#: the recorded hull row's pitch column
HULL_PITCH = list(HULL_VARS).index("pitch")
#: steps per call of the compiled loop (progress, faults and noise between calls)
CHUNK_STEPS = 2000
#: ... and when nothing happens between calls (no progress bar, no noise, no external
#: supervisor, no check of the model's validity; a fault still ends its chunk): fewer calls,
#: each of which costs ~45 µs to enter (its records' types checked), the same steps
QUIET_CHUNK_STEPS = 50_000
#: simulation.duration_s: auto: the record first holds this much of the run [s]
AUTO_FIRST_S = 10_000.0
#: step control where nothing moves (the pull): the longest block [s] ...
HELD_STEP_S = 1.0
#: ... taken only while every group's uplift is below its hold by this fraction of its H_0
HELD_MARGIN = 0.05


def simulate(scenario, control: str | None = None, duration: float | None = None,
             engine="table", progress=None, plant: Plant | None = None,
             share: bool = True, step_control: bool = True,
             stop_beyond: bool = False, summary_only: bool = False) -> Result:
    """Simulate the ascent of ``scenario``.

    Parameters
    ----------
    scenario : Scenario
        The lift (:func:`flexlift.load_scenario`).
    control : str, optional
        Control mode (default ``scenario.control.mode``): ``decentralized``, ``coordinated``,
        ``paper`` (decentralized control on the paper's uncoupled plant) or ``open-loop``.
    duration : float, optional
        Largest simulated time [s] (default ``simulation.duration_s``); the run stops earlier
        once every bag has held the target for ``simulation.hold_time_s``.
    engine : str or callable, optional
        The supervisor: ``"table"`` (lookup table, default), ``"exact"`` (exact inference at
        every sample, slower), a callable (points (n, 2) -> u (n,)) or a (supervisor, fill)
        pair of callables.
    progress : callable, optional
        ``progress(fraction)`` for a progress bar.
    plant : Plant, optional
        A prebuilt :class:`~flexlift.ascent.plant.Plant` (default: built from the scenario,
        the paper's plant in paper mode).
    share : bool, optional
        Identical bags at one lift point share the compiled loop's work (default;
        :mod:`flexlift.ascent.clusters`); False: the loop keeps every bag on its own (the same
        results, to rounding).
    step_control : bool, optional
        Where nothing moves (every holding group held, no bag filling or purging: the pull),
        take the time in blocks of up to ``HELD_STEP_S`` (:func:`held_steps`): the mechanics
        one step per block, the control sampled at its first step, the holding force and
        separation on every time step (:func:`flexlift.ascent.kernel.held_block`); False:
        every step alike (default True).
    stop_beyond : bool, optional
        End the run at the first chunk of the loop whose recorded pitch or strength
        snapshots' slope passes ``limits.slope_validity_deg`` (:meth:`Ascent.beyond`): what
        follows is outside the small-deflection model's validity. For the single-failure
        study (:mod:`flexlift.sweep.contingency.answer`), whose answer reads nothing after
        that moment; the rows up to it are those of a full run (default False: run on).
    summary_only : bool, optional
        Return the result's arrays in a plain :class:`~flexlift.ascent.result.Frame`, not an
        xarray Dataset: the same criteria, headline, events, outcome and arrays, for a caller
        that reads the summary only (a sweep's ``keep: summary``; default False).

    Returns
    -------
    Result
        ``result.dataset`` (xarray, units in every variable's attributes),
        ``result.criteria`` (name: passed), ``result.headline`` (the headline numbers, units
        in their names), ``result.events``.

    Examples
    --------
    >>> from flexlift import load_scenario
    >>> from flexlift.ascent import simulate
    >>> result = simulate(load_scenario("tanker"), control="coordinated")
    >>> all(result.criteria.values())
    True
    >>> round(result.headline["max_ascent_velocity_ms"], 2)  # [m/s], the limit is 0.6
    0.21
    """
    run = prepare(scenario, control, duration, engine, plant, share, step_control)
    run.stop_beyond = stop_beyond
    return run.run(progress, summary_only)


def prepare(scenario, control: str | None = None, duration: float | None = None,
            engine="table", plant: Plant | None = None, share: bool = True,
            step_control: bool = True) -> Ascent:
    """The run :func:`simulate` makes, checked and ready, not yet run (its parameters are
    :func:`simulate`'s): for :func:`flexlift.ascent.batch.run_batch`, which runs several
    together, or a caller that steps a run chunk by chunk (:meth:`Ascent.next_stop`)."""
    mode = control or scenario.control.mode
    if mode not in MODES:
        raise InputError("control", mode, f"use {', '.join(MODES)}")
    T_end = float(scenario.simulation.run_length_s if duration is None else duration)
    if not math.isfinite(T_end) or T_end <= 0:
        raise InputError("duration", duration, "must be a positive time [s]")
    if plant is None:
        plant = paper_plant(scenario) if mode == "paper" else coupled_plant(scenario)
    check_faults(scenario, plant.names)
    check_neutral(plant)
    refuse_unworkable(scenario, plant)
    if duration is None:
        warn_short(scenario, plant)
    share = share and mode != COMMANDED  # commands are per bag: no bag stands for another
    return Ascent(scenario, plant, mode, T_end, engine, share, step_control)


def held_steps(settings: Settings) -> int:
    """Base steps per block of step control where nothing moves (:func:`flexlift.ascent.
    kernel.held_block`): the largest divisor of the steps per recorded row (so every row is
    a block's first step) that is a multiple of the steps per control sample (so every
    block's first step is a sample) and whose length is at most ``HELD_STEP_S``; 1 (off) if
    none is longer than one step."""
    best = 1
    for m in range(1, settings.k_out + 1):
        if (settings.k_out % m == 0 and m % settings.k_ctrl == 0
                and m * settings.dt <= HELD_STEP_S + 1e-9):
            best = m
    return best


class Ascent:
    """One run: the records of the compiled loop and what happens between its chunks.

    The plant's records are ``plant.modal``, ``.strips``, ``.bags`` and ``.seabed``; the
    run's are ``controllers``, ``control_state``, ``state``, ``switches``, ``settings`` and
    ``recorder`` (:class:`~flexlift.ascent.records.LoopInputs`).

    Identical bags at one lift point share a bag of the loop (``share``, default True;
    :mod:`flexlift.ascent.clusters`): ``records`` are the plant's records as the loop reads
    them, ``clusters`` which bags share; during the run the state, switches and record hold
    one entry per loop bag, and once it ends one per bag of the plant. ``step_control``
    (default True): where nothing moves (the pull), the time is taken in blocks of
    :func:`held_steps` base steps (:func:`flexlift.ascent.kernel.held_block`)."""

    def __init__(self, scenario, plant: Plant, mode: str, T_end: float, engine,
                 share: bool = True, step_control: bool = True):
        sim, lim, c = scenario.simulation, scenario.limits, scenario.control
        self.scenario, self.plant, self.mode = scenario, plant, mode
        dt = sim.time_step_s
        table, self.external, fill = fuzzy_maps(scenario, engine)
        controllers, self.control_state = controller_for(scenario, plant, mode, table, fill)
        self.clusters = find_clusters(scenario, plant, controllers, share)
        self.records = loop_records(plant.records, self.clusters)
        self.controllers = loop_controllers(controllers, self.clusters)
        if self.clusters.shared:
            self.control_state = new_state(self.controllers.bags.size)
        modal, strips, bags, seabed = self.records
        self.settings = Settings(
            dt=dt, n_steps=int(math.ceil(T_end / dt - 1e-9)),
            k_ctrl=max(1, int(round(1.0 / c.sample_rate_Hz / dt))),
            k_out=max(1, int(round(sim.output_interval_s / dt))),
            k_str=max(1, int(round(sim.strength_interval_s / dt))),
            target=c.target_height_m, tol=lim.arrival_tolerance_m, hold_time=sim.hold_time_s,
            v_limit=lim.ascent_velocity_m_s, v_down_limit=lim.descent_velocity_m_s,
            pitch_limit=math.radians(90.0 if lim.pitch_deg is None else lim.pitch_deg),
            top_limit=bags.water_depth - lim.surface_clearance_m - bags.top_offset,
            external=self.external is not None, held_steps=1, held_margin=HELD_MARGIN,
            release_step=float(released_holding(1.0, dt, seabed.release_time)))
        if step_control:
            self.settings = self.settings._replace(held_steps=held_steps(self.settings))
        self.state = new_run_state(modal.nr, bags.nb, strips.ns, seabed.ng,
                                   bags.gen_strip.shape[0])
        self.switches = new_switches(bags.nb, strips.ns)
        self.switches.current[0] = scenario.disturbance.current_m_s
        # simulation.duration_s: auto: buffers for a first stretch, grown as the run goes on
        first = self.settings.n_steps if sim.duration_s != "auto" else min(
            self.settings.n_steps, int(AUTO_FIRST_S / dt))
        self.recorder = new_record(first, self.settings.k_out, self.settings.k_str, bags.nb,
                                   modal.nr, seabed.ng, strips.ns)
        self.force_noise = ForceNoise(scenario, dt, plant.strip_element, plant.hull.n_elements)
        self.meas_noise = MeasurementNoise(scenario, bags.nb)
        self.faults = sorted(scenario.faults, key=lambda f: f.time_s)
        self.fault_events: list[tuple[float, str, str, str]] = []
        self.stop_beyond = False  # simulate(stop_beyond=...)
        self._seen = [0, 0]  # rows and snapshots already checked by beyond()
        self._initial_state()

    def _expected_steps(self) -> int:
        """The steps the run is expected to take (for an even progress bar): the plan's
        separation, rise and hold (:func:`flexlift.ascent.checks.planned_run`), at most the
        run's length; the run's length when the plan cannot say."""
        need = planned_run(self.scenario, self.plant)[2]
        steps = self.settings.n_steps
        return min(steps, math.ceil(need / self.settings.dt)) if math.isfinite(need) else steps

    def inputs(self) -> LoopInputs:
        """The compiled loop's records, as they are now (the switches' noise changes between
        chunks)."""
        return LoopInputs(plant=self.records, controllers=self.controllers,
                          control_state=self.control_state, state=self.state,
                          switches=self.switches, settings=self.settings,
                          recorder=self.recorder)

    def _initial_state(self) -> None:
        """Neutral gas, the full hold, and the structure at rest on the held seabed springs."""
        state = self.state
        state.n[:] = self.plant.initial_moles()[self.clusters.first]
        state.H[:] = self.plant.seabed.H0
        state.H_rate[:] = np.nan
        kernel.initial_equilibrium(self.inputs())

    def run(self, progress=None, summary_only: bool = False) -> Result:
        """Run to the end, chunk by chunk (:meth:`start`, :meth:`next_stop`, the compiled
        loop, :meth:`after_chunk`, :meth:`finish`); :func:`flexlift.ascent.batch.run_batch`
        takes the same steps for several runs, with one compiled call per chunk for all."""
        self.start(progress)
        while (k_stop := self.next_stop()) is not None:
            if self.after_chunk(self._advance(k_stop)):
                break
        return self.finish(summary_only)

    def start(self, progress=None) -> None:
        """Before the first chunk: where the run stands and how it reports progress."""
        self._progress, self._fi = progress, 0
        self._whole = self._expected_steps() if progress is not None else self.settings.n_steps
        between = (progress is not None or self.stop_beyond or self.external is not None
                   or self.force_noise.on or self.meas_noise.on)
        self._chunk = CHUNK_STEPS if between else QUIET_CHUNK_STEPS

    def next_stop(self, until: int | None = None) -> int | None:
        """Apply the faults due, draw the next chunk's noise and room in the record; the step
        the next chunk runs to (exclusive; at most ``until``), or None once the run is past
        its last step (or at ``until``)."""
        settings, state = self.settings, self.state
        k = int(state.counters[0])
        if k > settings.n_steps or (until is not None and k >= until):
            return None
        while self._fi < len(self.faults) and fault_step(self.faults[self._fi], settings.dt) <= k:
            self._fault(self.faults[self._fi], k * settings.dt)
            self._fi += 1
        k_stop = min(k + self._chunk, settings.n_steps + 1,
                     settings.n_steps + 1 if until is None else until)
        if self._fi < len(self.faults):
            k_stop = min(k_stop, max(fault_step(self.faults[self._fi], settings.dt), k + 1))
        self._noise(k, k_stop)
        self._room(k_stop)
        return k_stop

    def after_chunk(self, code: int) -> bool:
        """After a chunk that ended with ``code`` (not ``RET_NEED_U``): progress; whether the
        run ends here (a stop, or past the model's validity with ``stop_beyond``)."""
        if self._progress is not None:  # 100 % only at the end, whenever that comes
            self._progress(min(self.state.counters[0] / max(self._whole, 1), 0.99))
        return code == RET_STOP or (self.stop_beyond and self.beyond())

    def finish(self, summary_only: bool = False) -> Result:
        """The result, after the last chunk (raises :class:`SimulationError` with the partial
        result when the numerics failed)."""
        recorder, error = self.recorder, None
        if recorder.ev_code[:recorder.counts[2]].tolist().count(EV_NUMERICS):
            error = f"numerics failed at t = {self.state.counters[0] * self.settings.dt:.1f} s: " \
                    "the state is not finite or blew up"
        elif recorder.counts[0] == 0 or recorder.t[recorder.counts[0] - 1] != self._t_last():
            kernel.final_row(self._t_last(), self.inputs())
        if self._progress is not None:
            self._progress(1.0)
        self._per_bag()
        result = build_result(self, error, summary_only)
        if error:
            raise SimulationError(error + " (results kept up to that moment)", partial=result)
        return result

    def beyond(self) -> bool:
        """Whether a row recorded or a strength snapshot taken since the last call has the
        hull's pitch or the structure's largest slope past ``limits.slope_validity_deg``
        (what :func:`flexlift.sweep.contingency.answer.validity_time` reads of the result)."""
        from flexlift.ascent.plant import slope_at
        from flexlift.ascent.strength import strength_grid

        rec, lim = self.recorder, math.radians(self.scenario.limits.slope_validity_deg)
        rows, snaps = int(rec.counts[0]), int(rec.counts[1])
        r0, s0 = self._seen
        self._seen = [rows, snaps]
        pitch = rec.hull[r0:rows, HULL_PITCH]
        if pitch.size and np.abs(pitch).max() > lim:
            return True
        if snaps <= s0 or self.plant.kind != "coupled":
            return False
        if not hasattr(self, "_slope_rows"):  # the slope of the retained modes on the grid
            x, _, keep = strength_grid(self.plant)
            self._slope_rows = slope_at(self.plant.modes, x[keep])[:, : self.plant.modal.nr].T
        slope = np.abs(np.arctan(rec.snap_q[s0:snaps] @ self._slope_rows))
        return bool(slope.max() > lim)

    def _t_last(self) -> float:
        return (int(self.state.counters[0]) - 1) * self.settings.dt

    def _advance(self, k_stop: int) -> int:
        """The compiled loop to ``k_stop``, evaluating an external supervisor when asked."""
        while True:
            code = kernel.advance(self.inputs(), k_stop)
            if code != RET_NEED_U:
                return code
            self.external_supervisor()

    def external_supervisor(self) -> None:
        """The external supervisor's outputs for the samples the loop asked for
        (``RET_NEED_U``), set where the loop reads them."""
        cs = self.control_state
        u = np.asarray(self.external(np.column_stack([cs.e_in, cs.r_in])), dtype=float)
        cs.u[:] = np.where(np.isnan(cs.t_sep), 0.0, u.reshape(-1))

    def _room(self, k_stop: int) -> None:
        """Grow the record (doubling) so that it holds the rows and snapshots to ``k_stop``."""
        settings, rec, p = self.settings, self.recorder, self.records
        if (k_stop // settings.k_out + 2 <= rec.t.size
                and k_stop // settings.k_str + 2 <= rec.snap_t.size):
            return
        steps = min(max(2 * (rec.t.size - 2) * settings.k_out, k_stop), settings.n_steps)
        new = new_record(steps, settings.k_out, settings.k_str, p.bags.nb, p.modal.nr,
                         p.seabed.ng, p.strips.ns)
        for old, big in zip(rec, new):
            big[: old.shape[0]] = old
        self.recorder = new

    def _fault(self, fault, t: float) -> None:
        names = [self.plant.names[i] for i in self.clusters.first]  # a faulted bag: its own
        detail = apply_fault(fault, t, names, self.switches,
                             self.controllers.bags, self.control_state)
        # a held block ends here (kernel.held_block): the steps after a fault are base steps
        # (the held structure's mechanics were taken to the block's end at its first step:
        # it barely moves; the force extrapolation restarts). Outside a block: nothing.
        if self.state.counters[1] & F_HELD:
            self.state.counters[1] &= ~(F_HELD | F_QUIET | F_STILL | F_HAVE_B)
        self.fault_events.append((t, fault.kind, fault.bag, detail))

    def command(self, bag: int, fill: float | None = None, opening: float | None = None) -> None:
        """Commanded mode: set the valves of controlled bag ``bag`` (index among
        ``controllers.bags``) between chunks: ``fill`` [m^3/s at the bag's pressure] and purge
        ``opening`` [-]; None leaves a valve where it is. Ends a held block of step control
        (the valves act from the next step, as :meth:`_fault` does)."""
        if self.mode != COMMANDED:
            raise ValueError(f"valves are commanded only in {COMMANDED} mode, not {self.mode}")
        cs = self.control_state
        if fill is not None:
            cs.fill[bag] = min(max(float(fill), 0.0), self.controllers.fill_max)
        if opening is not None:
            cs.opening[bag] = min(max(float(opening), 0.0), 1.0)
        self.end_held_block()

    def end_held_block(self) -> None:
        """End a held block of step control (:func:`flexlift.ascent.kernel.held_block`): the
        steps from here are base steps, the force extrapolation restarts. For a change made
        to the run between chunks (a command, an estimator's update of the state)."""
        if self.state.counters[1] & F_HELD:
            self.state.counters[1] &= ~(F_HELD | F_QUIET | F_STILL | F_HAVE_B)

    def fork(self, mode: str | None = None) -> Ascent:
        """A copy that runs on from here on its own: its state, switches, controller state,
        record, faults and noise generators copied; the plant and the loop's records shared
        (read only). For a forecast: the copy run to its end leaves this run where it is.

        ``mode`` (another control mode): the copy's valves are run from here by that mode's
        controllers, taking over now with fresh memory (their filters start from the
        readings, a separation already past is noted at their first sample, the valves keep
        their settings until it): "if this controller took over now"."""
        twin = copy.copy(self)
        for name in ("state", "switches", "control_state", "recorder"):
            value = getattr(self, name)
            setattr(twin, name, type(value)(*[_copied(a) for a in value]))
        if mode is not None and mode != self.mode:
            if mode not in MODES or mode in ("paper", COMMANDED) or self.external is not None:
                raise ValueError(f"a fork takes over with the decentralized or coordinated "
                                 f"controller on a table engine, not {mode!r}")
            table, _, fill = fuzzy_maps(self.scenario, "table")
            controllers, _ = controller_for(self.scenario, self.plant, mode, table, fill)
            twin.controllers = loop_controllers(controllers, self.clusters)
            twin.control_state = new_state(twin.controllers.bags.size)
            twin.control_state.fill[:] = self.control_state.fill
            twin.control_state.opening[:] = self.control_state.opening
            twin.mode = mode
            twin.end_held_block()
        twin.faults, twin.fault_events = list(self.faults), list(self.fault_events)
        twin.force_noise, twin.meas_noise = (copy.deepcopy(self.force_noise),
                                             copy.deepcopy(self.meas_noise))
        twin._seen = list(self._seen)
        return twin

    def _per_bag(self) -> None:
        """The state, switches and record with one entry per bag of the plant (each bag's
        loop bag's), at the end of the run."""
        cl = self.clusters
        if not cl.shared:
            return
        nr, ns, ng = self.plant.modal.nr, self.plant.strips.ns, self.plant.seabed.ng
        ne = self.state.row_force.shape[1]
        self.state = expand(self.state, lambda n: new_run_state(nr, n, ns, ng, ne), cl)
        self.switches = expand(self.switches, lambda n: new_switches(n, ns), cl)
        rec = self.recorder
        used = {rec.snap_t.size: int(rec.counts[1])}  # the buffers' rows used
        used[rec.t.size] = max(int(rec.counts[0]), used.get(rec.t.size, 0))
        self.recorder = expand_events(
            expand(rec, lambda n: new_record(1, 1, 1, n, nr, ng, ns), cl, used), cl)

    def _noise(self, k0: int, k1: int) -> None:
        """Noise rows of steps k0 .. k1 - 1 and of their control samples."""
        sw, settings = self.switches, self.settings
        if self.force_noise.on:
            self.switches = sw = sw._replace(noise=self.force_noise.rows(k1 - k0))
            sw.chunk[0] = k0
        if self.meas_noise.on:
            j0, j1 = k0 // settings.k_ctrl, (k1 - 1) // settings.k_ctrl
            self.switches = sw = sw._replace(meas_noise=self.meas_noise.rows(j0, j1))
            sw.chunk[1] = j0


def _copied(value):
    """A record field's own copy (arrays copied; numbers as they are)."""
    return value.copy() if isinstance(value, np.ndarray) else value
