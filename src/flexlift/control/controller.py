"""The ascent controllers (docs/theory/control.md) of all controlled bags at once: one compiled controller.

Each control sample (zero-order hold at ``control.sample_rate_Hz``) takes the measured height
[m], vertical speed [m/s] and gas volume [m^3] of every controlled (external) bag and does,
per bag:

1. **Measurement filter**: first-order low-pass of height and speed (time constant
   ``filter_time``), so the retained flexible modes are not chased.
2. **Reference** z_ref(t), ż_ref(t): the trapezoid of :mod:`flexlift.control.reference` from
   the height at separation (each bag's own in decentralized mode; the bags' mean in
   coordinated mode) to the target, or where the purge valves could not keep up with the gas
   expansion, the slower profile of :mod:`flexlift.control.profile`.
3. **Supervisor**: normalised error e = (z_ref - z) / e_scale and rate r = (ż_ref - ż) / r_scale,
   saturated to [-1, 1], to u in [-1, 1] (the fuzzy map as a lookup table, or given from
   outside); desired volume V_d = V_neutral + I + u ΔV_max. I, the adapted neutral volume,
   integrates the height error (gain ``k_height``, at most ΔV_max either way, and only while
   |e| < :data:`ADAPT_BAND`, so transients do not wind it up) so that a bag whose share of the
   lift differs from its neutral volume still arrives: no steady error on an unbalanced hull. Before separation V_d holds the breakout pull.
4. **Coordination** (coordinated mode): V_d -= (k_θ θ + k_θ' θ') ξ_i, θ the slope of the
   least-squares line through the live bags' heights and ξ_i the bag's normalised lever (in a
   staged lift, through their height errors z - z_ref among the bags under way: the
   sequence tilts the structure on purpose, and levelling keeps each group on its plan).
5. **Fill**, SIFSMC on ε = V_d - V: s = ε' + λ ε (ε' a filtered difference, time constant
   :data:`DERIV_TAU`), d = s / sqrt(1 + λ^2) / d_scale -> the monotone fill map -> fill flow,
   only beyond the deadband.
6. **Purge**, PID on the excess V - V_d -> valve opening in [0, 1], from beyond the deadband and
   while its integral is positive; anti-windup by conditional integration. Fill is blocked
   while the valve is open.

**Staged lift** (``control.sequence``, :mod:`flexlift.control.sequence`): a bag is passive
until its start time (it holds its neutral volume: no pull, no reference); from then it pulls,
and once the hold of its own stretch of the structure has let go (the plant gives each stage
its own stretch of the seabed's suction) its reference begins from the height it is at then
(in coordinated mode, the mean of the bags starting with it): the structure peels off the
seabed stage by stage. Without a sequence every start time is 0 and nothing changes.

Modes: decentralized (each bag on its own measurements; the moment of separation is the one
shared signal), coordinated, open-loop (fill to the breakout volume, never purge) and
commanded (the valves as commanded from outside the loop: ``fill`` [m^3/s] and ``opening``
[-] of :class:`ControlState` are set between chunks, by :meth:`flexlift.ascent.loop.Ascent.
command`, and a valve with no new command stays where it is, as a real one does: ``act``
leaves them alone; the rig of :mod:`flexlift.live.rig` drives the plant so). The paper's
configuration is decentralized control on the paper's plant.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from flexlift._jit import inline_jit, jit
from flexlift._struct import as_struct
from flexlift.control.reference import trapezoid
from flexlift.fuzzy.tables import bilinear, linear

#: time constant of the filter on the volume-deficit derivative of the SIFSMC [s]
DERIV_TAU = 1.0
#: the neutral volume adapts only while the normalised height error is below this: it removes
#: a small steady error and does not wind up during the transients of breakout
ADAPT_BAND = 0.25
#: control modes inside the compiled loop
DECENTRALIZED, COORDINATED, OPEN_LOOP, COMMANDED = 0, 1, 2, 3
MODE_CODES = {"decentralized": DECENTRALIZED, "coordinated": COORDINATED, "open-loop": OPEN_LOOP,
              "paper": DECENTRALIZED, "commanded": COMMANDED}


class ControlArrays(NamedTuple):
    """Controller constants (read only), SI; arrays over the nc controlled bags."""

    mode: int
    bags: np.ndarray  # (nc,) index of each controlled bag among the plant's bags
    period: float  # [s]
    target: float  # [m]
    speed: float  # [m/s]
    accel: float  # [m/s^2]
    lever: np.ndarray  # (nc,) normalised lever about the bags' centre [-]
    x: np.ndarray  # (nc,) bag points [m]
    V_neutral: np.ndarray  # (nc,) [m^3]
    V_pull: np.ndarray  # (nc,) breakout pull as gas volume [m^3]
    dV_max: np.ndarray  # (nc,) supervisor authority [m^3]
    e_scale: float  # [m]
    r_scale: float  # [m/s]
    lam: float  # [1/s]
    d_scale: float  # [m^3/s]
    kp: float  # [1/m^3]
    ki: float  # [1/(m^3 s)]
    kd: float  # [s/m^3]
    fill_max: float  # [m^3/s]
    deadband: float  # [m^3]
    k_pitch: float  # [m^3/rad]
    k_pitch_rate: float  # [m^3 s/rad]
    k_height: float  # adaptation of the neutral volume per metre of error [m^3/(m s)]
    filter_time: float  # measurement low-pass time constant (0: none) [s]
    filter_gain: float  # its gain per sample, 1 - exp(-period / filter_time) [-]
    ref_T: float  # duration of the valve-limited planned ascent (0: the plain trapezoid) [s]
    ref_z: np.ndarray  # its height from 0 to the target, evenly over [0, ref_T] [m]
    ref_v: np.ndarray  # its speed [m/s]
    table: np.ndarray  # (g, g) supervisor u on [-1, 1]^2
    fill_v: np.ndarray  # (m,) fill map: fill fraction (non-decreasing) at normalised distances
    #                     evenly over [0, 1] (0 below, 1 above)
    start: np.ndarray  # (nc,) start time of each bag in a staged lift (all 0 if not staged) [s]
    staged: bool  # a staged lift: per-group reference starts, levelling on the height errors
    weight: np.ndarray  # (nc,) the identical bags each controller stands for (1; a cluster's
    #                     count, flexlift.ascent.clusters): its weight in the means and the fit


class ControlState(NamedTuple):
    """The controllers' memory (mutable arrays over the nc controlled bags)."""

    integ: np.ndarray  # purge PID integral [m^3 s]
    prev_eps: np.ndarray  # last volume deficit [m^3]
    eps_rate: np.ndarray  # filtered deficit rate [m^3/s]
    prev_excess: np.ndarray  # last excess (PID derivative) [m^3]
    adapt: np.ndarray  # adapted neutral volume I [m^3]
    z_f: np.ndarray  # filtered height [m]
    zd_f: np.ndarray  # filtered speed [m/s]
    t_sep: np.ndarray  # separation time of each bag's hold (nan: not yet) [s]
    z0: np.ndarray  # reference start height [m]
    active: np.ndarray  # bool: False once a bag is lost
    e_in: np.ndarray  # supervisor inputs of the last sample (normalised, saturated)
    r_in: np.ndarray
    u: np.ndarray  # supervisor output [-]
    V_d: np.ndarray  # desired volume [m^3]
    z_ref: np.ndarray  # reference height [m]
    zd_ref: np.ndarray  # reference speed [m/s]
    t_free: np.ndarray  # time the bag's hold let go (nan: not yet) [s]
    started: np.ndarray  # bool: the bag's start time in a staged lift has come
    fill: np.ndarray  # fill flow command [m^3/s]
    opening: np.ndarray  # purge valve opening [-]
    flags: np.ndarray  # [0] first sample done, [1] some bag separated
    in_z: np.ndarray  # scratch: this sample's measured heights, speeds, volumes, separations
    in_zd: np.ndarray
    in_V: np.ndarray
    in_sep: np.ndarray


def new_state(nc: int) -> ControlState:
    """The controllers' memory before the first sample."""
    z = np.zeros
    return ControlState(z(nc), z(nc), z(nc), z(nc), z(nc), z(nc), z(nc), np.full(nc, np.nan),
                        z(nc), np.ones(nc, dtype=np.bool_), z(nc), z(nc), z(nc), z(nc), z(nc),
                        z(nc), np.full(nc, np.nan), np.zeros(nc, dtype=np.bool_), z(nc), z(nc),
                        np.zeros(2, dtype=np.bool_), z(nc), z(nc), z(nc),
                        np.zeros(nc, dtype=np.bool_))


@inline_jit
def observe(t, z, zd, separated, controllers, control_state):
    """Filter the measurements, note separations, form the reference and the supervisor's
    inputs (into ``control_state``: ``e_in``, ``r_in``, ``z_ref``). ``z``, ``zd`` (nc,)
    measured heights [m] and speeds [m/s]; ``separated`` (nc,) bool, the hold of each bag has
    let go. ``controllers``: their constants (:class:`ControlArrays`); ``control_state``: their
    memory (:class:`ControlState`)."""
    nc = z.size
    if not control_state.flags[0]:
        control_state.z_f[:] = z
        control_state.zd_f[:] = zd
    elif controllers.filter_time > 0.0:
        a = controllers.filter_gain  # 1 - exp(-period / filter_time)
        for i in range(nc):  # element by element: no temporary arrays at every sample
            control_state.z_f[i] += a * (z[i] - control_state.z_f[i])
            control_state.zd_f[i] += a * (zd[i] - control_state.zd_f[i])
    else:
        control_state.z_f[:] = z
        control_state.zd_f[:] = zd
    for i in range(nc):
        control_state.started[i] = t >= controllers.start[i] - 1e-9
        if separated[i] and math.isnan(control_state.t_free[i]):
            control_state.t_free[i] = t
    _note_separations(t, separated, controllers, control_state)
    for i in range(nc):
        if math.isnan(control_state.t_sep[i]) or controllers.mode == OPEN_LOOP:
            control_state.z_ref[i], control_state.zd_ref[i] = 0.0, 0.0
            control_state.e_in[i], control_state.r_in[i] = 0.0, 0.0
            continue
        pos, vel = reference(t - control_state.t_sep[i], controllers.target - control_state.z0[i],
                             controllers)
        control_state.z_ref[i], control_state.zd_ref[i] = control_state.z0[i] + pos, vel
        e = (control_state.z_ref[i] - control_state.z_f[i]) / controllers.e_scale
        control_state.e_in[i] = min(max(e, -1.0), 1.0)
        r = (vel - control_state.zd_f[i]) / controllers.r_scale
        control_state.r_in[i] = min(max(r, -1.0), 1.0)
        if (control_state.active[i] and controllers.k_height > 0.0
                and abs(control_state.e_in[i]) < ADAPT_BAND):
            lim = controllers.dV_max[i]
            step = (controllers.period * controllers.k_height
                    * (control_state.z_ref[i] - control_state.z_f[i]))
            control_state.adapt[i] = min(max(control_state.adapt[i] + step, -lim), lim)


@inline_jit
def reference(tau, distance, controllers):
    """(position [m], velocity [m/s]) along the planned ascent ``tau`` [s] after its start over
    ``distance`` [m]: the trapezoid, or the valve-limited profile scaled to the distance."""
    if controllers.ref_T <= 0.0:
        return trapezoid(tau, distance, controllers.speed, controllers.accel)
    k = distance / controllers.target
    return (k * linear(controllers.ref_z, 0.0, controllers.ref_T, tau),
            k * linear(controllers.ref_v, 0.0, controllers.ref_T, tau))


@inline_jit
def _note_separations(t, separated, controllers, control_state):
    """Start the reference of every bag whose hold has let go and whose start time has come."""
    new = False
    for i in range(separated.size):
        if (math.isnan(control_state.t_sep[i]) and not math.isnan(control_state.t_free[i])
                and control_state.started[i]):
            control_state.t_sep[i] = t
            new = True
    if not new:
        return
    control_state.flags[1] = True
    if controllers.mode == COORDINATED and controllers.staged:  # each group: its bags' mean
        total, count = 0.0, 0.0
        for i in range(control_state.z_f.size):
            if control_state.t_sep[i] == t and control_state.active[i]:
                total += controllers.weight[i] * control_state.z_f[i]
                count += controllers.weight[i]
        for i in range(control_state.z_f.size):
            if control_state.t_sep[i] == t:
                control_state.z0[i] = total / count if count else control_state.z_f[i]
    elif controllers.mode == COORDINATED:  # one heave reference from the live bags' mean height
        total, count = 0.0, 0.0
        for i in range(control_state.z_f.size):
            if control_state.active[i]:
                total += controllers.weight[i] * control_state.z_f[i]
                count += controllers.weight[i]
        mean = total / count if count else 0.0
        for i in range(control_state.z_f.size):
            control_state.z0[i] = mean
    else:
        for i in range(control_state.z_f.size):
            if control_state.t_sep[i] == t:
                control_state.z0[i] = control_state.z_f[i]


@inline_jit
def supervise(controllers, control_state):
    """The supervisor's output from the lookup table, into ``control_state.u`` (0 before
    separation)."""
    for i in range(control_state.u.size):
        if math.isnan(control_state.t_sep[i]) or controllers.mode == OPEN_LOOP:
            control_state.u[i] = 0.0
        else:
            control_state.u[i] = bilinear(controllers.table, -1.0, 1.0, -1.0, 1.0,
                                          control_state.e_in[i], control_state.r_in[i])


@inline_jit
def act(volume, controllers, control_state):
    """Desired volumes, fill and purge commands from ``control_state.u`` and the measured
    volumes ``volume`` (nc,) [m^3], into ``control_state``: ``V_d``, ``fill`` [m^3/s] and
    ``opening`` [-]. Commanded mode: the commands set from outside stay as they are."""
    nc = volume.size
    if controllers.mode == COMMANDED:
        control_state.flags[0] = True
        return
    for i in range(nc):
        if math.isnan(control_state.t_sep[i]) or controllers.mode == OPEN_LOOP:
            # held: the pull from its start
            pull = controllers.V_pull[i] if control_state.started[i] else 0.0
            control_state.V_d[i] = controllers.V_neutral[i] + pull
        else:
            control_state.V_d[i] = (controllers.V_neutral[i] + control_state.adapt[i]
                                    + control_state.u[i] * controllers.dV_max[i])
    if controllers.mode == COORDINATED:
        _level(controllers, control_state)
    a = controllers.period / (DERIV_TAU + controllers.period)
    gain = 1.0 / math.sqrt(1.0 + controllers.lam * controllers.lam) / controllers.d_scale
    for i in range(nc):
        eps = control_state.V_d[i] - volume[i]
        prev = control_state.prev_eps[i] if control_state.flags[0] else eps
        control_state.eps_rate[i] += a * ((eps - prev) / controllers.period
                                          - control_state.eps_rate[i])
        control_state.prev_eps[i] = eps
        d = min(max((control_state.eps_rate[i] + controllers.lam * eps) * gain, -1.0), 1.0)
        fill = (linear(controllers.fill_v, 0.0, 1.0, d) * controllers.fill_max
                if eps > controllers.deadband else 0.0)
        opening = 0.0
        if controllers.mode != OPEN_LOOP:
            opening = _purge(i, -eps, controllers, control_state)
            if opening > 0.0:
                fill = 0.0
        if not control_state.active[i]:
            fill, opening = 0.0, 0.0
        control_state.fill[i], control_state.opening[i] = fill, opening
    control_state.flags[0] = True


@inline_jit
def _purge(i, excess, controllers, control_state):
    """PID valve opening [-] of bag ``i`` on the volume ``excess`` [m^3]; conditional
    integration: the integral holds while the valve is saturated open or the PID is off."""
    raw = controllers.kp * excess + controllers.ki * control_state.integ[i]
    if controllers.kd != 0.0:
        raw += controllers.kd * (excess - control_state.prev_excess[i]) / controllers.period
        control_state.prev_excess[i] = excess
    on = excess > controllers.deadband or control_state.integ[i] > 0.0
    hold = (raw >= 1.0 and excess > 0.0) or not on
    if not hold:
        control_state.integ[i] = max(control_state.integ[i] + excess * controllers.period, 0.0)
    return min(max(raw, 0.0), 1.0) if on else 0.0


@inline_jit
def _level(controllers, control_state):
    """Coordinated mode: the pitch-levelling correction of every desired volume (staged: of
    the bags under way, on their height errors); each bag weighted by the bags it stands for."""
    total, count = 0.0, 0.0
    for i in range(control_state.z_f.size):
        if _levelled(i, controllers, control_state):
            total += controllers.weight[i] * controllers.x[i]
            count += controllers.weight[i]
    if count < 2:
        return
    mean = total / count
    xx, xz, xzd = 0.0, 0.0, 0.0
    for i in range(control_state.z_f.size):
        if _levelled(i, controllers, control_state):
            d = controllers.x[i] - mean
            wd = controllers.weight[i] * d
            xx += wd * d
            if controllers.staged:
                xz += wd * (control_state.z_f[i] - control_state.z_ref[i])
                xzd += wd * (control_state.zd_f[i] - control_state.zd_ref[i])
            else:
                xz += wd * control_state.z_f[i]
                xzd += wd * control_state.zd_f[i]
    if xx <= 0.0:
        return
    corr = controllers.k_pitch * xz / xx + controllers.k_pitch_rate * xzd / xx
    if not controllers.staged:
        for i in range(control_state.z_f.size):
            control_state.V_d[i] -= corr * controllers.lever[i]
        return
    half = 0.0  # the levers of the bags under way, about their own centre
    for i in range(control_state.z_f.size):
        if _levelled(i, controllers, control_state):
            half = max(half, abs(controllers.x[i] - mean))
    for i in range(control_state.z_f.size):
        if _levelled(i, controllers, control_state):
            control_state.V_d[i] -= corr * (controllers.x[i] - mean) / half


@inline_jit
def _levelled(i, controllers, control_state):
    """Whether bag ``i`` takes part in the levelling: live, and in a staged lift under way."""
    return control_state.active[i] and (not controllers.staged
                                        or not math.isnan(control_state.t_sep[i]))


@jit
def sample(t, z, zd, volume, separated, controllers, control_state):
    """One whole control sample (observe, supervise from the table, act) on the named tuples
    ``controllers`` (:class:`ControlArrays`) and ``control_state`` (:class:`ControlState`), as
    the compiled loop does it; for Python callers and tests."""
    constants, memory = as_struct(controllers), as_struct(control_state)
    observe(t, z, zd, separated, constants, memory)
    supervise(constants, memory)
    act(volume, constants, memory)
