"""The time-domain ascent: the loop, its events and faults (SPEC §8).

:func:`simulate` integrates the coupled plant of :mod:`flexlift.plant` with a fixed step
``simulation.time_step_s`` and the controllers of :mod:`flexlift.control` sampled at
``control.sample_rate_Hz`` (zero-order hold). The ``paper`` mode runs the uncoupled per-bag
plant of :mod:`flexlift.paper` through the same loop.

Integrator: while the hull is held it sits in quasi-static equilibrium on the seabed springs
and only the gas and the holding force (second-order Adams-Bashforth) advance. Once separated,
the mechanical states use second-order exponential time differencing (ETD2): exact for the
linear part (modal stiffness and damping and the seabed springs active at the step's start;
matrices cached per contact pattern), with the other generalised forces (drag, buoyancy,
suction) varying linearly over the step, extrapolated from the previous one. So the stiff
parts (the contact penalty, flexible modes up to ~90 rad/s) are integrated exactly at
dt = 0.1 s. While the hull is on or near the seabed, contact springs switch inside the step,
so there the mechanics take ``CONTACT_SUBSTEPS`` sub-steps. The gas states are advanced
explicitly (time scales of tens of seconds) and the holding force decays exactly during its
release. Separation is checked at the end of each step, located inside it by interpolation
(so the controllers sampling at the next step see it) and the hull moves freely for the rest
of that step; breakout and arrival times are interpolated inside the step too. Halving the
time step changes the headline results by well under 1 %. Spill and relief venting are
instantaneous projections after each step.

The run stops when every bag point has held within ``limits.arrival_tolerance_m`` of the
target for ``simulation.hold_time_s``, when a bag breaches the surface (the model ends at the
surface), at ``simulation.duration_s``, or with :class:`~flexlift.errors.SimulationError` (its
``partial`` the result so far) when the numerics fail.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from flexlift import constants as C
from flexlift.control import Controller, control_params, fuzzy_engines
from flexlift.errors import InputError, SimulationError
from flexlift.plant import Fast, Switches, build_plant, dynamics, etd_matrices, held_state, uplift
from flexlift.recorder import Recorder
from flexlift.results import Result

log = logging.getLogger(__name__)

#: a hull is clear of the seabed once every point is this high [m]
LIFTOFF_CLEARANCE = 0.05
#: mechanical sub-steps per time step while the hull is on or near the seabed (contact switching)
CONTACT_SUBSTEPS = 5


def _substeps(x, t0, span, n, dx, aux, b_prev, u, params, tau, gas):
    """The separated hull over ``span`` [s] from ``t0`` in ``n`` ETD2 sub-steps, the dynamics
    evaluated at each (``dx, aux`` at the start given; ``b_prev`` the generalised force one full
    step of ``span`` earlier, or None); the gas advanced too when ``gas``. Returns the new state."""
    P = params[0]
    nr, nb = P.nr, P.nb
    m2 = 2 * nr
    h = span / n
    cache = params[3].setdefault(round(h, 12), {})
    xj, aj, dxj = x.copy(), aux, dx
    b = aux.Qext
    bp = b if b_prev is None else b - (b - b_prev) * (h / span)
    decay = math.exp(-h / tau)
    for j in range(n):
        if j:
            dxj, aj = dynamics(t0 + j * h, xj, u, params)
        E, A, B, _ = _etd(cache, P, h, aj.active)
        bj = aj.Qext
        xj[:m2] = E @ xj[:m2] + A @ bj + B @ bp
        if gas:
            xj[m2 : m2 + nb] += h * dxj[m2 : m2 + nb]
        xj[-1] *= decay
        bp = bj
    return xj


def _etd(cache, P, h, active):
    """ETD2 matrices (E, A, B, [E A B]) for a step ``h`` [s] and contact pattern ``active``,
    cached per pattern."""
    # no contact (None or all False) gives the same matrices under either key
    key = active.tobytes() if active is not None else None
    mats = cache.get(key)
    if mats is None:
        E, A, B = etd_matrices(P, h, active)
        mats = cache[key] = (E, A, B, np.hstack([E, A, B]))  # the last: one product per step
    return mats


def check_faults(scenario, names) -> None:
    """InputError for a fault that names an unknown bag."""
    for k, f in enumerate(scenario.faults):
        if f.bag not in names:
            raise InputError(f"faults[{k}].bag", f.bag, f"known bags are {', '.join(names)}")


def check_neutral(P) -> None:
    """InputError when the bags cannot hold the hull neutral at the start (SPEC §5): the
    internal bags full and the external bags sharing the rest of W' must fit their capacities."""
    V = P.neutral_volumes()
    to_t = P.gas.rho / 1000.0  # m^3 of displaced water -> tonnes of lift
    if not P.external.any() or np.any(V < -1e-9):
        internal_t = float(P.capacity[~P.external].sum()) * to_t
        raise InputError(
            "lift",
            f"{internal_t:.0f} t of internal bags for {P.wet_weight / P.gas.g / 1000:.0f} t wet weight",
            "the internal bags alone must lift less than the wet weight and there must be an "
            "external bag to control; change internal_bags or bag_lift_t",
        )
    over = V > P.capacity * (1 + 1e-9)
    if over.any():
        k = int(np.flatnonzero(over)[0])
        raise InputError(
            f"lift.bags.{P.names[k]}",
            f"{V[k] * to_t:.0f} t needed at the start",
            f"each external bag must hold its share of the wet weight, but it lifts at most "
            f"{P.capacity[k] * to_t:.0f} t; raise bag_lift_t or add bags",
        )


def simulate(scenario, control: str | None = None, duration: float | None = None,
             engine="table", progress=None, plant=None) -> Result:
    """Simulate the ascent of ``scenario``.

    control : control mode (default ``scenario.control.mode``)
    duration : largest simulated time [s] (default ``simulation.duration_s``)
    engine : fuzzy engine, "table" (default), "exact" or a (supervisor, fill) pair
    progress : optional callable(fraction) for a progress bar
    plant : a prebuilt :class:`~flexlift.plant.Plant` (default: built from the scenario)
    """
    mode = control or scenario.control.mode
    if mode not in ("decentralized", "coordinated", "paper", "open-loop"):
        raise InputError("control", mode, "use decentralized, coordinated, paper or open-loop")
    sim = scenario.simulation
    T_end = float(duration if duration is not None else sim.duration_s)
    if not math.isfinite(T_end) or T_end <= 0:
        raise InputError("duration", duration, "must be a positive time [s]")
    P = plant or build_plant(scenario)
    check_faults(scenario, P.names)
    check_neutral(P)
    if mode == "paper":
        from flexlift.paper import simulate_paper

        return simulate_paper(scenario, T_end, engine, progress)
    return _run(scenario, P, mode, T_end, engine, progress)


def _run(scenario, P, mode, T_end, engine, progress) -> Result:
    sim, lim, env = scenario.simulation, scenario.limits, scenario.environment
    dt = sim.time_step_s
    n_steps = int(math.ceil(T_end / dt - 1e-9))
    period = 1.0 / scenario.control.sample_rate_Hz
    k_ctrl = max(1, int(round(period / dt)))
    nr, nb = P.nr, P.nb
    ext = np.flatnonzero(P.external)
    rho, g = env.seawater_density_kg_m3, env.gravity_m_s2
    hold_centroid = float(P.ws @ (P.hold_s * P.xs))
    cp = control_params(scenario, P.x_point[ext], P.neutral_volumes()[ext], P.capacity[ext],
                        rho, g, hold_centroid, mode)
    sup, fill = fuzzy_engines(scenario, engine)
    ctrl = Controller(cp, sup, fill)
    sw = Switches(nb, P.xs.size)
    dist = scenario.disturbance
    sw.current = dist.current_m_s
    rng = np.random.default_rng(dist.seed)
    noise_el = np.zeros(P.hull.n_elements)
    ou_a = math.exp(-dt / dist.noise_time_s)
    ou_b = dist.force_noise_N_m * math.sqrt(1 - ou_a**2)
    strips_per_el = P.xs.size // P.hull.n_elements
    c = scenario.control
    meas_rng = np.random.default_rng(dist.seed + 1)
    noisy = c.height_noise_m > 0 or c.velocity_noise_m_s > 0 or c.volume_noise_m3 > 0
    # sensor faults on the controlled bags
    drift = np.zeros(nb)
    drift_t0 = np.zeros(nb)
    frozen = np.zeros(nb, dtype=bool)
    frozen_until = np.full(nb, np.inf)
    faults = sorted(scenario.faults, key=lambda f: f.time_s)
    fi = 0
    name_idx = {n: i for i, n in enumerate(P.names)}
    ctrl_idx = {int(b): k for k, b in enumerate(ext)}
    # the controlled bags as a slice when they are consecutive (cheaper than fancy indexing)
    if ext.size and np.all(np.diff(ext) == 1):
        ext_ix, ext_u = slice(int(ext[0]), int(ext[-1]) + 1), slice(nb + int(ext[0]), nb + int(ext[-1]) + 1)
    else:
        ext_ix, ext_u = ext, nb + ext

    x = P.initial_state()
    u = np.zeros(2 * nb)
    F = Fast(P)
    ppT = np.ascontiguousarray(F.pp.T)
    x[:nr] = held_state(F, x, sw)
    params = (P, sw, F, {})  # the last: ETD2 matrices of sub-steps, per step length
    sw.noisy = dist.force_noise_N_m > 0
    sw.rates = False  # the mechanics are stepped by ETD2 (or held static): no rates needed
    etd_cache = {}
    tau = P.seabed.release_time
    decay = math.exp(-dt / tau)
    b_prev = None  # generalised force of the previous step (ETD2)
    Hdot_prev = Hdot_last = None  # held: rate of the holding force one step earlier
    z_prev = None
    rec = Recorder(P, scenario, mode, dt)
    last = (np.zeros(nb), np.zeros(nb), np.zeros(nb))
    cmd = (np.zeros(ext.size), np.zeros(ext.size), np.zeros(ext.size), np.zeros(ext.size))
    H0 = P.seabed.H0
    tol, target = lim.arrival_tolerance_m, c.target_height_m
    hold_time = sim.hold_time_s
    hold_since = None
    top_limit = env.water_depth_m - lim.surface_clearance_m - P.top_offset
    top_min = float(top_limit.min())
    error = None
    m2 = 2 * nr
    nsl = slice(m2, m2 + nb)
    closed = ~P.external
    relief = np.where(closed, P.gas.relief, 0.0)
    cap_RT = P.capacity * (1.0 / F.RT)  # the most gas a bag holds per unit pressure [mol/Pa]
    relief_RT = relief * cap_RT
    report_every = max(1, n_steps // 100)
    any_sensor_fault = False
    leaking = False
    n_faults = len(faults)
    t = 0.0
    idle_until = -1  # held and idle up to this step: only the holding force changes
    idle_dH = 0.0
    idle_decay = 1.0 - ctrl.a_filt
    for k in range(n_steps + 1):
        t = k * dt
        if k < idle_until:
            # held and idle (valves shut and staying shut, no faults or noise): the gas and the
            # hull's static state are constant, the holding force falls linearly
            if k % k_ctrl == 0:
                ctrl.eps_rate *= idle_decay  # the controller's filtered deficit rate decays
            if k % rec.k_out == 0 or k % rec.k_str == 0:
                sw.full = True
                _, aux = dynamics(t, x, u, params)
                rec.sample(k, t, x, aux, u, cmd, ext, sw)
            x[-1] += idle_dH
            continue
        while fi < n_faults and faults[fi].time_s <= t + 1e-12:
            f = faults[fi]
            i = name_idx[f.bag]
            detail = ""
            if f.kind == "bag_rupture":
                sw.leak[i] = 1.0 / f.leak_time_s
                sw.intact = False
                leaking = True
            elif f.kind == "sling_break":
                sw.attached[i] = 0.0
                sw.intact = False
                if i in ctrl_idx:
                    ctrl.lose(ctrl_idx[i])
            elif f.kind == "supply_failure":
                sw.supply[i] = 0.0
                sw.intact = False
            elif f.kind == "sensor_drift":
                drift[i], drift_t0[i] = f.rate_m_s, t
            elif f.kind == "sensor_stuck":
                frozen[i] = True
            elif f.kind == "sensor_dropout":
                frozen[i], frozen_until[i] = True, t + f.duration_s
            if f.kind.startswith("sensor"):
                any_sensor_fault = True
                if i not in ctrl_idx:
                    detail = "no controller on this bag: no effect"
            rec.event(t, f.kind, f.bag, detail)
            fi += 1
        if sw.noisy:
            noise_el = ou_a * noise_el + ou_b * rng.standard_normal(noise_el.size)
            sw.noise_s = np.repeat(noise_el, strips_per_el)
        if k % k_ctrl == 0:
            # measurements: what the controllers see
            zm, zdm = x[:m2].reshape(2, nr) @ ppT  # heights and velocities at the bag points
            pm = F.p_atm + F.rg * np.maximum(F.depth - zm, 0.0)
            Vm = np.minimum(x[nsl] * (F.RT / pm), F.cap)
            sw.meas = (zm, zdm, pm, Vm)  # the dynamics of this state reuse them
            if any_sensor_fault:
                zm = zm + drift * np.maximum(t - drift_t0, 0.0)
            if noisy:
                zm = zm + c.height_noise_m * meas_rng.standard_normal(nb)
                zdm = zdm + c.velocity_noise_m_s * meas_rng.standard_normal(nb)
                Vm = Vm + c.volume_noise_m3 * meas_rng.standard_normal(nb)
            if any_sensor_fault:
                frozen &= t < frozen_until
                zm = np.where(frozen, last[0], zm)
                zdm = np.where(frozen, last[1], zdm)
                Vm = np.where(frozen, last[2], Vm)
                last = (zm, zdm, Vm)
            cmd = ctrl.step(t, zm[ext_ix], zdm[ext_ix], Vm[ext_ix], sw.separated)
            u[ext_ix] = cmd[0]
            u[ext_u] = cmd[1]
        sw.full = k % rec.k_out == 0 or k % rec.k_str == 0
        dx, aux = dynamics(t, x, u, params)
        sw.meas = None
        if not sw.separated:  # held: the hull sits in quasi-static equilibrium on the seabed
            Qh = F.Gb @ aux.point + F.Qw
            x[:nr] = F.static @ (Qh + F.G @ sw.noise_s if sw.noisy else Qh)
        rec.sample(k, t, x, aux, u, cmd, ext, sw)
        # events on the current state
        zmax = max(aux.z.tolist())
        if zmax > top_min:
            live = (aux.z > top_limit) & (sw.attached > 0)
            if live.any():
                rec.event(t, "surface_breach", P.names[int(np.argmax(live))], "the run ends at the surface")
                break
        if sw.separated:
            if zmax < target - tol:  # no bag near the target yet
                hold_since = None
            else:
                within = np.abs(aux.z - target) <= tol
                if not rec.all_arrived:
                    rec.arrivals(t, within, z_prev, aux.z, target - tol, target + tol, dt)
                if within.all() or (within | (sw.attached == 0)).all():
                    hold_since = t if hold_since is None else hold_since
                    if t - hold_since >= hold_time - 1e-9:
                        rec.event(t, "target_held", None, f"held {hold_time:.0f} s")
                        break
                else:
                    hold_since = None
        if k == n_steps:
            break
        # step: linearly implicit trapezoidal rule on the mechanics, explicit on the rest
        z_prev = aux.z
        step = dt * dx
        if sw.separated:
            # mechanics: exact for the linear part (modes, damping, active contact springs),
            # second order in the rest (ETD2); holding force: exact exponential release
            H_old, t_old = x[-1], t  # the holding force at the start of its release in this step
            b = aux.Qext
            if aux.w_min < LIFTOFF_CLEARANCE:
                # on or near the seabed: contact springs engage and release inside the step;
                # sub-steps keep those switches off the coarse step grid
                xj = _substeps(x, t, dt, CONTACT_SUBSTEPS, dx, aux, b_prev, u, params, tau, True)
                step = xj - x
            else:
                M = _etd(etd_cache, P, dt, aux.active)[3]  # [E A B]
                xm = x[:m2]
                step[:m2] = M @ np.concatenate((xm, b, b if b_prev is None else b_prev)) - xm
                step[-1] = H_old * (decay - 1.0)
            b_prev = b
        else:
            step[:m2] = 0.0
            H_before = x[-1]
            Hdot = dx[-1]  # held: the holding force decays at a rate set by the pull (AB2)
            if Hdot_prev is not None:
                step[-1] = dt * (1.5 * Hdot - 0.5 * Hdot_prev)
            Hdot_last, Hdot_prev = Hdot_prev, Hdot
        x += step
        rec.account(aux, dt)
        # spill (open bags) and relief venting (closed bags) at the local pressure
        over = x[nsl] - (aux.pressure * cap_RT + relief_RT)
        if max(over.tolist()) > 0.0:
            over = np.maximum(over, 0.0)
            rec.vent(over * F.RT / aux.pressure)
            x[nsl] -= over
        if x[-1] < 0.0:
            x[-1] = 0.0
        if not sw.separated:
            # separation inside this step, checked on the new state so that the controllers
            # sampling at t + dt see it: located by linear interpolation of uplift minus holding
            # force, then the hull moves freely for the rest of the step (events off the grid)
            gap_new = uplift(F, x, sw) - x[-1]
            if gap_new > 0.0:
                gap = aux.uplift - H_before
                th = min(max(gap / (gap - gap_new), 0.0), 1.0) if gap <= 0.0 else 0.0
                rest = (1.0 - th) * dt
                H_s = H_before + th * (x[-1] - H_before)
                sw.separated = True
                rec.event(t + th * dt, "separation", None, f"uplift {aux.uplift / (C.TONNE * g):.0f} t")
                x[-1] = H_s
                H_old, t_old = H_s, t + th * dt  # separated inside the step: release from here
                if rest > 0.0:
                    dx_s, aux_s = dynamics(t + dt, x, u, params)
                    x[:] = _substeps(x, t + dt - rest, rest, CONTACT_SUBSTEPS, dx_s, aux_s, None, u,
                                     params, tau, False)
            elif (k % k_ctrl == 0 and not (sw.noisy or noisy or leaking or any_sensor_fault)
                  and Hdot == Hdot_last and ctrl.idle(cp.deadband)):
                # idle from here: skip to a few steps before the separation or the next fault
                n_sep = (x[-1] - aux.uplift) / (-dt * Hdot) if Hdot < 0.0 else math.inf
                k_end = min(n_steps, k + 1 + int(min(n_sep, 1e9)) - 2)
                if fi < n_faults:
                    k_end = min(k_end, int(math.ceil(faults[fi].time_s / dt - 1e-9)) - 1)
                # the uplift must be unchanged by the step (to round-off: a real trickle of
                # gas is far larger than 1e-12 of the uplift and keeps the loop stepping)
                if k_end > k + 1 and abs(aux.uplift - uplift(F, x, sw)) <= 1e-12 * abs(aux.uplift):
                    idle_until, idle_dH = k_end, dt * Hdot
        if leaking:
            x[nsl] = np.maximum(x[nsl], 0.0)
        if sw.separated and x[-1] < 1e-3 * H0 and not rec.has("breakout"):
            t_b = t_old + tau * math.log(H_old / (1e-3 * H0)) if H_old > 1e-3 * H0 else t_old
            rec.event(t_b, "breakout", None, "holding force below 0.1 % of H0")
        if k % report_every == 0:
            if progress is not None:
                progress(k / n_steps)
            if not np.all(np.isfinite(x)) or np.abs(x[:m2]).max() > 1e9:
                error = f"numerics failed at t = {t + dt:.1f} s: the state is not finite or blew up"
                break
    if progress is not None:
        progress(1.0)
    result = rec.finish(error)
    if error:
        raise SimulationError(error + " (results kept up to that moment)", partial=result)
    return result
