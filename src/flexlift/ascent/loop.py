"""``simulate``: the ascent of a scenario, for any plant and control mode (SPEC §8).

The compiled loop (:mod:`flexlift.ascent.kernel`) runs in chunks; between chunks this module
applies the faults due, draws the next chunk of noise, evaluates an external supervisor when
one is used, and reports progress. The run stops when every bag point has held within
``limits.arrival_tolerance_m`` of the target for ``simulation.hold_time_s``, when a bag
breaches the surface (the model ends there), at ``simulation.duration_s`` (``auto``: the
longest run the scenario's limits allow, the record grown as it goes), or with
:class:`~flexlift.errors.SimulationError` (its ``partial`` the result so far) when the
numerics fail.
"""

from __future__ import annotations

import math

import numpy as np

from flexlift.ascent import kernel
from flexlift.ascent.checks import refuse_unworkable, warn_short
from flexlift.ascent.faults import apply_fault, check_faults, fault_step
from flexlift.ascent.noise import ForceNoise, MeasurementNoise
from flexlift.ascent.paper import paper_plant
from flexlift.ascent.plant import Plant, check_neutral, coupled_plant
from flexlift.ascent.result import Result, build_result
from flexlift.ascent.state import (
    EV_NUMERICS,
    RET_NEED_U,
    RET_STOP,
    Settings,
    new_record,
    new_run_state,
    new_switches,
)
from flexlift.control.build import controller_for, fuzzy_maps
from flexlift.errors import InputError, SimulationError

MODES = ("decentralized", "coordinated", "paper", "open-loop")
#: steps per call of the compiled loop (progress, faults and noise between calls)
CHUNK_STEPS = 2000
#: simulation.duration_s: auto: the record first holds this much of the run [s]
AUTO_FIRST_S = 10_000.0


def simulate(scenario, control: str | None = None, duration: float | None = None,
             engine="table", progress=None, plant: Plant | None = None) -> Result:
    """Simulate the ascent of ``scenario``.

    Parameters
    ----------
    scenario : Scenario
        The lift (:func:`flexlift.scenario.load_scenario`).
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

    Returns
    -------
    Result
        ``result.dataset`` (xarray, units in every variable's attributes),
        ``result.criteria`` (name: passed), ``result.headline`` (the headline numbers, units
        in their names), ``result.events``.

    Examples
    --------
    >>> from flexlift.scenario import load_scenario
    >>> from flexlift.ascent import simulate
    >>> result = simulate(load_scenario("tanker"), control="coordinated")
    >>> all(result.criteria.values())
    True
    >>> round(result.headline["max_ascent_velocity_ms"], 2)  # [m/s], the limit is 0.6
    0.21
    """
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
    return Ascent(scenario, plant, mode, T_end, engine).run(progress)


class Ascent:
    """One run: the arrays of the compiled loop and what happens between its chunks."""

    def __init__(self, scenario, plant: Plant, mode: str, T_end: float, engine):
        sim, lim, c = scenario.simulation, scenario.limits, scenario.control
        self.scenario, self.plant, self.mode = scenario, plant, mode
        a = self.A = plant.arrays
        dt = sim.time_step_s
        table, self.external, fill = fuzzy_maps(scenario, engine)
        self.C, self.S = controller_for(scenario, plant, mode, table, fill)
        self.X = Settings(
            dt=dt, n_steps=int(math.ceil(T_end / dt - 1e-9)),
            k_ctrl=max(1, int(round(1.0 / c.sample_rate_Hz / dt))),
            k_out=max(1, int(round(sim.output_interval_s / dt))),
            k_str=max(1, int(round(sim.strength_interval_s / dt))),
            target=c.target_height_m, tol=lim.arrival_tolerance_m, hold_time=sim.hold_time_s,
            v_limit=lim.ascent_velocity_m_s, v_down_limit=lim.descent_velocity_m_s,
            pitch_limit=math.radians(lim.pitch_deg),
            top_limit=a.water_depth - lim.surface_clearance_m - a.top_offset,
            external=self.external is not None)
        self.R = new_run_state(a.nr, a.nb, a.ns, a.ng)
        self.W = new_switches(a.nb, a.ns)
        self.W.current[0] = scenario.disturbance.current_m_s
        # simulation.duration_s: auto: buffers for a first stretch, grown as the run goes on
        first = self.X.n_steps if sim.duration_s != "auto" else min(
            self.X.n_steps, int(AUTO_FIRST_S / dt))
        self.rec = new_record(first, self.X.k_out, self.X.k_str, a.nb, a.nr, a.ng, a.ns)
        self.force_noise = ForceNoise(scenario, dt, plant.strip_element, plant.hull.n_elements)
        self.meas_noise = MeasurementNoise(scenario, a.nb)
        self.faults = sorted(scenario.faults, key=lambda f: f.time_s)
        self.fault_events: list[tuple[float, str, str, str]] = []
        self._initial_state()

    def _initial_state(self) -> None:
        """Neutral gas, the full hold, and the structure at rest on the held seabed springs."""
        R = self.R
        R.n[:] = self.plant.initial_moles()
        R.H[:] = self.A.H0
        R.H_rate[:] = np.nan
        kernel.initial_equilibrium(self.A, R, self.W)

    def run(self, progress=None) -> Result:
        X, R = self.X, self.R
        fi, error = 0, None
        while R.counters[0] <= X.n_steps:
            k = int(R.counters[0])
            while fi < len(self.faults) and fault_step(self.faults[fi], X.dt) <= k:
                self._fault(self.faults[fi], k * X.dt)
                fi += 1
            k_stop = min(k + CHUNK_STEPS, X.n_steps + 1)
            if fi < len(self.faults):
                k_stop = min(k_stop, max(fault_step(self.faults[fi], X.dt), k + 1))
            self._noise(k, k_stop)
            self._room(k_stop)
            code = self._advance(k_stop)
            if progress is not None:
                progress(min(R.counters[0] / max(X.n_steps, 1), 1.0))
            if code == RET_STOP:
                break
        if self.rec.ev_code[:self.rec.counts[2]].tolist().count(EV_NUMERICS):
            error = f"numerics failed at t = {R.counters[0] * X.dt:.1f} s: the state is not " \
                    "finite or blew up"
        elif self.rec.counts[0] == 0 or self.rec.t[self.rec.counts[0] - 1] != self._t_last():
            kernel.final_row(self._t_last(), self.A, self.C, self.S, R, self.W, self.rec)
        if progress is not None:
            progress(1.0)
        result = build_result(self, error)
        if error:
            raise SimulationError(error + " (results kept up to that moment)", partial=result)
        return result

    def _t_last(self) -> float:
        return (int(self.R.counters[0]) - 1) * self.X.dt

    def _advance(self, k_stop: int) -> int:
        """The compiled loop to ``k_stop``, evaluating an external supervisor when asked."""
        while True:
            code = kernel.advance(self.A, self.C, self.S, self.R, self.W, self.X, self.rec, k_stop)
            if code != RET_NEED_U:
                return code
            S = self.S
            u = np.asarray(self.external(np.column_stack([S.e_in, S.r_in])), dtype=float)
            S.u[:] = np.where(np.isnan(S.t_sep), 0.0, u.reshape(-1))

    def _room(self, k_stop: int) -> None:
        """Grow the record (doubling) so that it holds the rows and snapshots to ``k_stop``."""
        X, rec = self.X, self.rec
        if (k_stop // X.k_out + 2 <= rec.t.size and k_stop // X.k_str + 2 <= rec.snap_t.size):
            return
        a = self.A
        steps = min(max(2 * (rec.t.size - 2) * X.k_out, k_stop), X.n_steps)
        new = new_record(steps, X.k_out, X.k_str, a.nb, a.nr, a.ng, a.ns)
        for old, big in zip(rec, new):
            big[: old.shape[0]] = old
        self.rec = new

    def _fault(self, fault, t: float) -> None:
        detail = apply_fault(fault, t, list(self.plant.names), self.W, self.C.bags, self.S)
        self.fault_events.append((t, fault.kind, fault.bag, detail))

    def _noise(self, k0: int, k1: int) -> None:
        """Noise rows of steps k0 .. k1 - 1 and of their control samples."""
        W, X = self.W, self.X
        if self.force_noise.on:
            self.W = W = W._replace(noise=self.force_noise.rows(k1 - k0))
            W.chunk[0] = k0
        if self.meas_noise.on:
            j0, j1 = k0 // X.k_ctrl, (k1 - 1) // X.k_ctrl
            self.W = W = W._replace(meas_noise=self.meas_noise.rows(j0, j1))
            W.chunk[1] = j0
