"""The compiled time step of the ascent: one loop for every plant and control mode.

Each step k (t = k dt), in order:

1. the bags' heights, speeds, pressures and gas volumes at the state;
2. a control sample every ``k_ctrl`` steps (:mod:`flexlift.control.controller`): measured
   values with sensor faults and noise, the supervisor (lookup table, or evaluated outside
   the loop: the loop returns ``RET_NEED_U`` and is called again), fill and purge commands
   held until the next sample;
3. the loads (:mod:`flexlift.ascent.mechanics`), a recorded row and strength snapshot at their
   intervals, the events of the state (surface breach, limits, lift-off, resettling, arrival,
   the target held);
4. the step: the mechanics by the trapezoidal rule (contact implicit; five sub-steps while the
   structure is on or near the seabed after separation), the gas explicitly (fill, purge,
   leak, then spill and relief venting at the new pressure), the holding force (held: its
   rate by Adams-Bashforth 2; released: exactly), separation located inside the step and seen
   by the next control sample, breakout.

Faults and noise chunks are set between calls by :mod:`flexlift.ascent.loop`.
"""

from __future__ import annotations

import math

import numpy as np

from flexlift._jit import jit
from flexlift._struct import as_struct
from flexlift.ascent.linalg import dot
from flexlift.ascent.mechanics import (
    bag_forces,
    bag_gas,
    bag_motion,
    contact_matrices,
    generalised_force,
    implicit_matrix,
    strip_loads,
    trapezoidal_step,
    update_contact_matrices,
)
from flexlift.ascent.recording import group_uplift, log_event, store_row, store_snapshot  # noqa: F401
from flexlift.ascent.state import (
    CONTACT_SUBSTEPS,
    EV_ARRIVAL,
    EV_BREAKOUT,
    EV_LIFTOFF,
    EV_LIMIT_DESCENT,
    EV_LIMIT_PITCH,
    EV_LIMIT_VELOCITY,
    EV_NUMERICS,
    EV_RESETTLE,
    EV_SEPARATION,
    EV_SURFACE_BREACH,
    EV_TARGET_HELD,
    F_FRESH,
    F_HAVE_B,
    F_LIFTOFF,
    F_LIMIT_D,
    F_LIMIT_P,
    F_LIMIT_V,
    F_MATRIX,
    F_OBSERVED,
    F_RESETTLE,
    RET_DONE,
    RET_NEED_U,
    RET_STOP,
)
from flexlift.control.controller import act, observe, supervise
from flexlift.physics.gas import (
    ambient_pressure,
    free_air,
    gas_volume,
    moles_rate,
    purge_flow,
    vented_moles,
)
from flexlift.physics.seabed import COMPLETE_FRACTION, holding_rate, released_holding


@jit
def advance(A, C, S, R, W, X, rec, k_stop):
    """Run steps until step ``k_stop`` (exclusive), the end, or a stop; returns why
    (``RET_DONE``: reached k_stop or the last step, ``RET_STOP``, ``RET_NEED_U``). The
    arguments are the named tuples of :mod:`flexlift.ascent.state`, the plant's and the
    controller's arrays; inside, they are passed by reference (:func:`flexlift._struct.
    as_struct`)."""
    return _advance(as_struct(A), as_struct(C), as_struct(S), as_struct(R), as_struct(W),
                    as_struct(X), as_struct(rec), k_stop)


@jit
def initial_equilibrium(A, R, W):
    """The loads of the state in ``R`` (named tuples), and the modal coordinates at rest on
    the held seabed springs under them (least squares: the paper's bag models have a mode
    that their one spring does not hold)."""
    A, R, W = as_struct(A), as_struct(R), as_struct(W)
    bag_motion(A, R.q, R.v, R.z, R.zd)
    bag_gas(A, R.n, R.z, R.p, R.V)
    _loads_at_state(A, R, W, W.noise[0])
    contact_matrices(A, R.active, R.stiff, R.damp)
    K = R.stiff.copy()
    for i in range(A.nr):
        K[i, i] += A.omega2[i]
    R.q[:] = np.linalg.lstsq(K, R.b)[0]


@jit
def final_row(t, A, C, S, R, W, rec):
    """A recorded row of the current state (named tuples), at the end of a run."""
    store_row(t, as_struct(A), as_struct(C), as_struct(S), as_struct(R), as_struct(W),
              as_struct(rec))


@jit
def _advance(A, C, S, R, W, X, rec, k_stop):
    while R.counters[0] < k_stop:
        code = step(A, C, S, R, W, X, rec)
        if code != RET_DONE:
            return code
        if R.counters[0] > X.n_steps:
            return RET_DONE
    return RET_DONE


@jit
def step(A, C, S, R, W, X, rec):
    """One time step (module docstring); returns RET_DONE to go on."""
    k = R.counters[0]
    t = k * X.dt
    if not R.counters[1] & F_FRESH:  # the bags' motion and gas of this state, once
        bag_motion(A, R.q, R.v, R.z, R.zd)
        bag_gas(A, R.n, R.z, R.p, R.V)
        R.counters[1] |= F_FRESH
    if k % X.k_ctrl == 0 and control(t, k, A, C, S, R, W, X) == RET_NEED_U:
        return RET_NEED_U
    noise = W.noise[k - W.chunk[0]] if W.chunk[0] >= 0 else W.noise[0]
    cur = W.current[0]
    bag_forces(A, R.V, R.zd, W.attached, cur, R.point)
    w_min = strip_loads(A, R.q, R.v, R.H, R.sep, cur, noise, R.w, R.wv, R.line, R.contact,
                        R.active)
    generalised_force(A, R.line, R.point, R.b)
    if k % X.k_out == 0:
        store_row(t, A, C, S, R, W, rec)
    if k % X.k_str == 0:
        store_snapshot(t, A, R, W, noise, rec)
    if events(t, A, R, W, X, rec, w_min) != RET_DONE:
        return RET_STOP
    if k == X.n_steps:
        R.counters[0] = k + 1
        return RET_STOP
    rates(A, R, W, X)
    R.z_prev[:] = R.z
    R.work[4] = R.q
    R.work[5] = R.v
    mechanics(A, R, W, X, w_min, noise)
    finish_step(t, A, R, W, X, rec, noise)
    R.counters[0] = k + 1
    if k % 100 == 0 and not healthy(R):
        log_event(rec, t + X.dt, EV_NUMERICS, -1, 0.0)
        return RET_STOP
    return RET_DONE


@jit
def control(t, k, A, C, S, R, W, X):
    """A control sample: measure, observe, supervise, act; RET_NEED_U when the supervisor is
    evaluated outside (its inputs are then in S.e_in, S.r_in; call again with S.u set)."""
    if not R.counters[1] & F_OBSERVED:
        measure(t, k, A, R, W, X)
        for j in range(C.bags.size):
            i = C.bags[j]
            S.in_z[j], S.in_zd[j], S.in_sep[j] = R.meas[0, i], R.meas[1, i], R.sep[A.bag_group[i]]
        observe(t, S.in_z, S.in_zd, S.in_sep, C, S)
        if X.external:
            R.counters[1] |= F_OBSERVED
            return RET_NEED_U
        supervise(C, S)
    R.counters[1] &= ~F_OBSERVED
    for j in range(C.bags.size):
        S.in_V[j] = R.meas[2, C.bags[j]]
    act(S.in_V, C, S)
    for j in range(C.bags.size):
        R.fill[C.bags[j]], R.opening[C.bags[j]] = S.fill[j], S.opening[j]
    return RET_DONE


@jit
def measure(t, k, A, R, W, X):
    """What the sensors report, into R.meas (3, nb): height, speed and gas volume with drift,
    noise and stuck or dropped-out sensors (which repeat their last values)."""
    j = k // X.k_ctrl - W.chunk[1]
    noisy = W.chunk[1] >= 0
    for i in range(A.nb):
        zm = R.z[i] + W.drift[i] * max(t - W.drift_t0[i], 0.0)
        zdm, Vm = R.zd[i], R.V[i]
        if noisy:
            zm += W.meas_noise[j, 0, i]
            zdm += W.meas_noise[j, 1, i]
            Vm += W.meas_noise[j, 2, i]
        if W.frozen[i] and t >= W.frozen_until[i]:
            W.frozen[i] = False
        if W.frozen[i]:
            zm, zdm, Vm = W.last[0, i], W.last[1, i], W.last[2, i]
        W.last[0, i], W.last[1, i], W.last[2, i] = zm, zdm, Vm
        R.meas[0, i], R.meas[1, i], R.meas[2, i] = zm, zdm, Vm


@jit
def events(t, A, R, W, X, rec, w_min):
    """The events of the current state; RET_STOP ends the run (a breach, the target held)."""
    for i in range(A.nb):
        if W.attached[i] > 0.0 and R.z[i] > X.top_limit[i]:
            log_event(rec, t, EV_SURFACE_BREACH, i, R.z[i])
            return RET_STOP
    if not R.sep.any():
        return RET_DONE
    limits(t, A, R, W, X, rec)
    flags = R.counters[1]
    if R.sep.all() and not flags & F_RESETTLE:
        if not flags & F_LIFTOFF and w_min > A.liftoff_clearance:
            R.counters[1] |= F_LIFTOFF
            log_event(rec, t, EV_LIFTOFF, -1, w_min)
        elif flags & F_LIFTOFF and w_min < 0.0:
            R.counters[1] |= F_RESETTLE
            log_event(rec, t, EV_RESETTLE, -1, w_min)
    return arrivals(t, A, R, W, X, rec)


@jit
def limits(t, A, R, W, X, rec):
    """Running maxima of the bags' upward and downward speeds and of the pitch, and their
    limit events (once each)."""
    up, down, i_up, i_down = 0.0, 0.0, -1, -1
    for i in range(A.nb):
        s = R.zd[i] * W.attached[i]
        if s > up:
            up, i_up = s, i
        elif -s > down:
            down, i_down = -s, i
    if up > R.scalars[0]:
        R.scalars[0] = up
        if up > X.v_limit and not R.counters[1] & F_LIMIT_V:
            R.counters[1] |= F_LIMIT_V
            log_event(rec, t, EV_LIMIT_VELOCITY, i_up, up)
    if down > R.scalars[4]:
        R.scalars[4] = down
        if down > X.v_down_limit and not R.counters[1] & F_LIMIT_D:
            R.counters[1] |= F_LIMIT_D
            log_event(rec, t, EV_LIMIT_DESCENT, i_down, down)
    pitch = abs(math.atan(dot(A.pitch_row, R.q)))
    if pitch > R.scalars[1]:
        R.scalars[1] = pitch
        if pitch > X.pitch_limit and not R.counters[1] & F_LIMIT_P:
            R.counters[1] |= F_LIMIT_P
            log_event(rec, t, EV_LIMIT_PITCH, -1, pitch)


@jit
def arrivals(t, A, R, W, X, rec):
    """First arrivals within the tolerance (interpolated inside the step) and the hold."""
    lo, hi = X.target - X.tol, X.target + X.tol
    if R.z.max() < lo:
        R.scalars[2] = np.nan
        return RET_DONE
    held = True
    for i in range(A.nb):
        within = abs(R.z[i] - X.target) <= X.tol
        if within and math.isnan(R.arrival[i]):
            a, b = R.z_prev[i], R.z[i]
            edge = lo if a < lo else (hi if a > hi else np.nan)
            ta = t
            if not math.isnan(edge) and a != b:
                ta = t - X.dt + X.dt * min(max((edge - a) / (b - a), 0.0), 1.0)
            R.arrival[i] = ta
            log_event(rec, ta, EV_ARRIVAL, i, R.z[i])
        held = held and (within or W.attached[i] == 0.0)
    if not held:
        R.scalars[2] = np.nan
        return RET_DONE
    if math.isnan(R.scalars[2]):
        R.scalars[2] = t
    if t - R.scalars[2] >= X.hold_time - 1e-9:
        log_event(rec, t, EV_TARGET_HELD, -1, X.hold_time)
        return RET_STOP
    return RET_DONE


@jit
def rates(A, R, W, X):
    """Gas rates [mol/s] at the start of the step into R.ndot, the pressures and purge flows
    into R.flow0; the holding forces and uplift-minus-hold gaps at the start into R.H_old,
    R.gap."""
    for i in range(A.nb):
        fill = R.fill[i] * W.supply[i]
        purge = purge_flow(R.opening[i], R.V[i], A.capacity[i], A.purge_max)
        R.ndot[i] = moles_rate(R.p[i], fill, purge, A.RT) - W.leak[i] * R.n[i]
        R.flow0[0, i], R.flow0[1, i] = R.p[i], purge
    for g in range(A.ng):
        R.H_old[g] = R.H[g]
        R.gap[g] = group_uplift(A, R.V, W.attached, g) - R.H[g]


@jit
def mechanics(A, R, W, X, w_min, noise):
    """Advance the modal mechanics over the step (sub-steps near the seabed once free); the
    explicit force is extrapolated to mid-step from the previous step's (or sub-step's)."""
    dt = X.dt
    have_b = R.counters[1] & F_HAVE_B
    b_mid, b_old, b_start = R.work[0], R.work[1], R.work[2]
    if R.sep.any() and w_min < A.liftoff_clearance:
        h = dt / CONTACT_SUBSTEPS
        b_start[:] = R.b
        for i in range(A.nr):
            b_old[i] = R.b[i] - (R.b[i] - R.b_prev[i]) * (h / dt) if have_b else R.b[i]
        for j in range(CONTACT_SUBSTEPS):
            if j:
                _loads_at_state(A, R, W, noise)
            for i in range(A.nr):
                b_mid[i] = 1.5 * R.b[i] - 0.5 * b_old[i]
                b_old[i] = R.b[i]
            _implicit_step(A, R, h, b_mid)
        R.b_prev[:] = b_start
    else:
        for i in range(A.nr):
            b_mid[i] = 1.5 * R.b[i] - 0.5 * R.b_prev[i] if have_b else R.b[i]
        _implicit_step(A, R, dt, b_mid)
        R.b_prev[:] = R.b
    R.counters[1] |= F_HAVE_B


@jit
def _loads_at_state(A, R, W, noise):
    """The loads of the current (sub-step) state, into R."""
    bag_motion(A, R.q, R.v, R.z, R.zd)
    bag_gas(A, R.n, R.z, R.p, R.V)
    bag_forces(A, R.V, R.zd, W.attached, W.current[0], R.point)
    strip_loads(A, R.q, R.v, R.H, R.sep, W.current[0], noise, R.w, R.wv, R.line, R.contact,
                R.active)
    generalised_force(A, R.line, R.point, R.b)


@jit
def _implicit_step(A, R, h, b_mid):
    """One trapezoidal step of ``h`` [s]; the implicit matrix rebuilt when the contact
    pattern or the step length changed (the contact springs of the strips that changed
    added or taken away)."""
    valid = bool(R.counters[1] & F_MATRIX)
    changed = not valid
    if valid:
        for s in range(A.ns):
            if R.active[s] != R.last_active[s]:
                changed = True
                break
    if changed or R.scalars[3] != h:
        if not valid:
            contact_matrices(A, R.active, R.stiff, R.damp)
        elif changed:
            update_contact_matrices(A, R.active, R.last_active, R.stiff, R.damp)
        implicit_matrix(A, h, R.stiff, R.damp, R.implicit)
        R.last_active[:] = R.active
        R.scalars[3] = h
        R.counters[1] |= F_MATRIX
    trapezoidal_step(A, R.q, R.v, b_mid, h, R.implicit, R.stiff, R.damp, R.work[3])


@jit
def finish_step(t, A, R, W, X, rec, noise):
    """Gas, venting, holding force, separation and breakout at the end of the step; leaves
    the bags' motion and gas of the new state in R (fresh for the next step). A group that
    separated inside the step moves freely for the rest of it."""
    dt = X.dt
    bag_motion(A, R.q, R.v, R.z, R.zd)
    for i in range(A.nb):
        n = _gas_step(i, dt, A, R, W)
        p = R.p[i]
        out = vented_moles(n, p, A.capacity[i], A.relief[i], A.RT)  # spill, relief venting
        if out > 0.0:
            n -= out
            R.vented[i] += out * A.RT / p
            R.vented_free[i] += out * A.RT / A.p_atm
        R.n[i], R.p[i] = n, p
        R.V[i] = gas_volume(n, p, A.RT, A.capacity[i])
    R.counters[1] |= F_FRESH
    for g in range(A.ng):
        if R.sep[g]:
            R.H[g] = released_holding(R.H[g], dt, A.release_time)
        else:
            # the rate at the start of the step (its uplift, kept in R.gap + R.H_old), stepped by
            # Adams-Bashforth 2 with the previous step's
            rate = holding_rate(R.gap[g] + R.H_old[g], A.H0[g], A.breakout_time)
            prev = R.H_rate[g]
            R.H[g] += dt * (1.5 * rate - 0.5 * prev) if not math.isnan(prev) else dt * rate
            R.H_rate[g] = rate
        R.H[g] = max(R.H[g], 0.0)
    separations(t, A, R, W, X, rec, noise)
    breakouts(t, A, R, X, rec)


@jit
def _gas_step(i, dt, A, R, W):
    """Bag ``i``'s gas [mol] at the end of the step (Heun: the rates at the start and at an
    Euler prediction at the new height, averaged; the commands are held over the step), with
    the accounts of the step's flows; leaves the new pressure in R.p."""
    fill = R.fill[i] * W.supply[i]
    p0, purge0 = R.flow0[0, i], R.flow0[1, i]
    p1 = ambient_pressure(R.z[i], A.water_depth, A.p_atm, A.rho_g)
    n_pred = max(R.n[i] + dt * R.ndot[i], 0.0)
    purge1 = purge_flow(R.opening[i], gas_volume(n_pred, p1, A.RT, A.capacity[i]),
                        A.capacity[i], A.purge_max)
    ndot1 = moles_rate(p1, fill, purge1, A.RT) - W.leak[i] * n_pred
    R.gas_local[i] += fill * dt
    R.gas_free[i] += 0.5 * (free_air(fill * dt, p0, A.p_atm) + free_air(fill * dt, p1, A.p_atm))
    R.purged[i] += 0.5 * dt * (purge0 + purge1)
    R.purged_free[i] += 0.5 * dt * (free_air(purge0, p0, A.p_atm) + free_air(purge1, p1, A.p_atm))
    R.vented[i] += 0.5 * dt * W.leak[i] * A.RT * (R.n[i] / p0 + n_pred / p1)
    R.vented_free[i] += 0.5 * dt * W.leak[i] * A.RT * (R.n[i] + n_pred) / A.p_atm
    R.p[i] = p1
    return max(R.n[i] + 0.5 * dt * (R.ndot[i] + ndot1), 0.0)


@jit
def separations(t, A, R, W, X, rec, noise):
    """Held groups whose uplift now exceeds their hold separate, at a time interpolated
    inside the step; the mechanics of the step are then redone, held up to that time and free
    after it (sub-steps)."""
    new = np.zeros(A.ng, np.bool_)
    th_min = 1.0
    for g in range(A.ng):
        if R.sep[g]:
            continue
        gap = group_uplift(A, R.V, W.attached, g) - R.H[g]
        if gap > 0.0:
            g0 = R.gap[g]
            th = min(max(g0 / (g0 - gap), 0.0), 1.0) if g0 <= 0.0 else 0.0
            new[g] = True
            th_min = min(th_min, th)
            log_event(rec, t + th * X.dt, EV_SEPARATION, g, gap + R.H[g])
            # held up to the separation, released exactly from it
            H_sep = R.H_old[g] + th * (R.H[g] - R.H_old[g])
            R.H[g] = released_holding(H_sep, (1.0 - th) * X.dt, A.release_time)
            R.release[0, g], R.release[1, g] = t + th * X.dt, H_sep
    if not new.any():
        return
    R.q[:] = R.work[4]
    R.v[:] = R.work[5]
    for part, free in ((th_min * X.dt, False), ((1.0 - th_min) * X.dt, True)):
        if free:
            R.sep[:] = R.sep | new
        if part <= 0.0:
            continue
        h = part / CONTACT_SUBSTEPS
        for _ in range(CONTACT_SUBSTEPS):
            _loads_at_state(A, R, W, noise)
            _implicit_step(A, R, h, R.b)
    R.counters[1] &= ~F_HAVE_B  # the suction's load steps in: restart the extrapolation
    bag_motion(A, R.q, R.v, R.z, R.zd)
    bag_gas(A, R.n, R.z, R.p, R.V)


@jit
def breakouts(t, A, R, X, rec):
    """Breakout is complete once every group's released hold is below 0.1 % of its H_0; the
    time is where the exact release from the separation crosses that level."""
    for g in range(A.ng):
        thr = COMPLETE_FRACTION * A.H0[g]
        if R.sep[g] and not R.broken[g] and R.H[g] <= thr:
            R.broken[g] = True
            t_sep, H_sep = R.release[0, g], R.release[1, g]
            tb = t + X.dt
            if thr > 0.0 and H_sep > thr:
                tb = t_sep + A.release_time * math.log(H_sep / thr)
            if R.broken.all():
                log_event(rec, tb, EV_BREAKOUT, -1, R.H.sum())


@jit
def healthy(R):
    """False when the state is not finite or has blown up."""
    for i in range(R.q.size):
        if not (abs(R.q[i]) < 1e9 and abs(R.v[i]) < 1e9):
            return False
    for i in range(R.n.size):
        if not math.isfinite(R.n[i]):
            return False
    return True
