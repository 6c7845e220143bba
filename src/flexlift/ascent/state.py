"""The mutable state of one ascent, as arrays the compiled loop reads and writes.

- :class:`RunState`: the plant's state (modal coordinates and rates, gas, holding forces and
  separations), the commands held between control samples, the running accounts (gas, vented
  gas, maxima, arrivals) and work arrays, so a step allocates nothing;
- :class:`Switches`: what faults and disturbances change (slings, supplies, leaks, sensor
  faults, current, force and measurement noise), set by :mod:`flexlift.ascent.faults`;
- :class:`Settings`: the run's fixed numbers (time step, intervals, limits, target);
- :class:`Record`: preallocated output rows, strength snapshots and the event log. Each row
  copies what it keeps (no views into per-step arrays).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

# event codes written by the compiled loop (names in flexlift.ascent.events)
(EV_SEPARATION, EV_BREAKOUT, EV_ARRIVAL, EV_TARGET_HELD, EV_SURFACE_BREACH, EV_LIMIT_VELOCITY,
 EV_LIMIT_PITCH, EV_LIFTOFF, EV_RESETTLE, EV_NUMERICS, EV_LIMIT_DESCENT) = range(11)
# why the compiled loop returned
RET_DONE, RET_STOP, RET_NEED_U, RET_FULL = range(4)
#: mechanical sub-steps per time step while the structure is on or near the seabed
CONTACT_SUBSTEPS = 5
#: largest number of events kept
MAX_EVENTS = 512


class Settings(NamedTuple):
    """Fixed numbers of a run, SI."""

    dt: float  # time step [s]
    n_steps: int  # steps to the end of the run
    k_ctrl: int  # steps per control sample
    k_out: int  # steps per recorded row
    k_str: int  # steps per strength snapshot
    target: float  # target height [m]
    tol: float  # arrival tolerance [m]
    hold_time: float  # the target held this long ends the run [s]
    v_limit: float  # ascent velocity limit (upward) [m/s]
    v_down_limit: float  # descent velocity limit (downward, once separated) [m/s]
    pitch_limit: float  # pitch limit [rad]
    top_limit: np.ndarray  # (nb,) a bag point above this breaches the surface [m]
    external: bool  # the supervisor is evaluated outside the compiled loop
    held_steps: int  # step control where nothing moves (the pull): base steps per block
    #                  (1: off; kernel.held_block)
    held_margin: float  # ... only while every group's uplift is below its hold by this
    #                     fraction of its H_0 [-]
    release_step: float  # a released hold's factor over one step, exp(-dt / tau_r) [-]
    #                      (physics.seabed.released_holding of 1 N)


class Switches(NamedTuple):
    """Fault and disturbance switches (arrays, changed in place between calls)."""

    attached: np.ndarray  # (nb,) 1 while the sling holds, 0 after it breaks
    supply: np.ndarray  # (nb,) 1 while the gas supply works
    leak: np.ndarray  # (nb,) gas escape rate of a ruptured bag [1/s]
    drift: np.ndarray  # (nb,) height sensor drift [m/s]
    drift_t0: np.ndarray  # (nb,) when it began [s]
    frozen: np.ndarray  # (nb,) bool: the sensors hold their last values
    frozen_until: np.ndarray  # (nb,) [s]
    last: np.ndarray  # (3, nb) last measured height, speed, volume
    current: np.ndarray  # (1,) vertical current, up positive [m/s]
    noise: np.ndarray  # (steps, ns) random line load per strip, this chunk's steps [N/m]
    meas_noise: np.ndarray  # (samples, 3, nb) measurement noise of this chunk's samples
    chunk: np.ndarray  # (2,) int: first step / first sample of the noise rows (-1: no noise)
    dump_stuck: np.ndarray  # (nb,) bool: the dump (purge) valve stuck closed
    fill_stuck: np.ndarray  # (nb,) bool: the fill valve stuck open (fills at the full rate)


class RunState(NamedTuple):
    """The state of the ascent and the loop's memory (arrays, changed in place)."""

    q: np.ndarray  # (nr,) modal coordinates
    v: np.ndarray  # (nr,) their rates
    n: np.ndarray  # (nb,) gas [mol]
    H: np.ndarray  # (ng,) holding force [N]
    sep: np.ndarray  # (ng,) bool: separated
    broken: np.ndarray  # (ng,) bool: breakout complete
    release: np.ndarray  # (2, ng) when each group separated [s] and its hold then [N]
    H_rate: np.ndarray  # (ng,) last dH/dt while held [N/s]
    b_prev: np.ndarray  # (nr,) generalised force of the previous step
    fill: np.ndarray  # (nb,) fill command held [m^3/s]
    opening: np.ndarray  # (nb,) purge valve opening held [-]
    arrival: np.ndarray  # (nb,) first arrival at the target [s] (nan)
    z_prev: np.ndarray  # (nb,) heights at the previous step [m]
    gas_local: np.ndarray  # (nb,) gas filled, at local pressure [m^3]
    gas_free: np.ndarray  # (nb,) gas filled, as free air [m^3]
    vented: np.ndarray  # (nb,) gas spilled, vented or leaked, at local pressure [m^3]
    purged: np.ndarray  # (nb,) gas purged, at local pressure [m^3]
    vented_free: np.ndarray  # (nb,) the vented gas as free air at the surface [m^3]
    purged_free: np.ndarray  # (nb,) the purged gas as free air [m^3]
    counters: np.ndarray  # int: [0] step k, [1] flags (see F_*)
    scalars: np.ndarray  # float: [0] largest upward speed, [1] largest pitch, [2] hold since
    #                      (nan), [3] step of the cached implicit matrix (nan), [4] largest
    #                      downward speed once separated, [5] the largest pitch's |tan|
    # work arrays (no allocation per step)
    z: np.ndarray
    zd: np.ndarray
    p: np.ndarray
    V: np.ndarray  # (nb,)
    w: np.ndarray
    wv: np.ndarray
    line: np.ndarray  # (ns,) explicit line load (drag, noise, suction) [N/m]
    contact: np.ndarray  # (ns,) contact line load [N/m]
    active: np.ndarray  # (ns,) bool: contact spring in the implicit step
    last_active: np.ndarray  # (ns,) bool: the pattern of the cached implicit matrix
    point: np.ndarray  # (nb,) bag forces on the structure [N]
    b: np.ndarray  # (nr,) explicit generalised force
    implicit: np.ndarray  # (nr, nr) cached inverse of the implicit step matrix
    stiff: np.ndarray  # (nr, nr) contact stiffness in modal coordinates
    damp: np.ndarray  # (nr, nr) contact damping in modal coordinates
    meas: np.ndarray  # (3, nb) measured height, speed, volume
    work: np.ndarray  # (6, nr) scratch: mid-step force, previous sub-step force, force at the
    #                   start, trapezoidal work, q and q' at the start of the step
    ndot: np.ndarray  # (nb,) gas rates at the start of the step [mol/s]
    flow0: np.ndarray  # (2, nb) pressure [Pa] and purge flow [m^3/s] at the start of the step
    H_old: np.ndarray  # (ng,) holding forces at the start of the step [N]
    gap: np.ndarray  # (ng,) uplift minus hold at the start of the step [N]
    breached: np.ndarray  # (nb,) bool: the bag has breached the surface (its event logged)
    row_line: np.ndarray  # (ns,) scratch of a recorded row: the strips' whole line load [N/m]
    row_force: np.ndarray  # (2, ne) and its generalised forces on the eliminated modes, of
    #                        the line and the bags' point forces [N]


# flags in RunState.counters[1]
F_HAVE_B, F_MATRIX, F_LIFTOFF, F_RESETTLE, F_OBSERVED, F_LIMIT_V, F_LIMIT_P, F_FRESH, F_LIMIT_D = (
    1, 2, 4, 8, 16, 32, 64, 128, 256)
#: flag: the step is inside a held block of step control (its mechanics already advanced)
F_HELD = 512
#: flag: the held block's other steps step the hold only (kernel.quiet_step)
F_QUIET = 1024
#: flag: the previous step was a quiet block's inner step: since then nothing has changed but
#: the hold (kernel.quiet_step steps only the hold's part of the step's start)
F_STILL = 2048
#: flag: state.row_force[0] holds the eliminated modes' generalised forces of state.row_line
#: (recording.store_row)
F_ROW_LINE = 4096


class Record(NamedTuple):
    """Preallocated outputs: rows, strength snapshots and events (with their counts)."""

    t: np.ndarray  # (rows,)
    bag: np.ndarray  # (rows, 12, nb): the bag variables of flexlift.ascent.result.BAG_VARS
    hull: np.ndarray  # (rows, 5): the hull variables of flexlift.ascent.result.HULL_VARS
    snap_t: np.ndarray  # (snaps,)
    snap_q: np.ndarray  # (snaps, nr)
    snap_v: np.ndarray
    snap_a: np.ndarray
    snap_H: np.ndarray  # (snaps, ng)
    snap_sep: np.ndarray  # (snaps, ng) bool
    snap_V: np.ndarray  # (snaps, nb)
    snap_attached: np.ndarray  # (snaps, nb)
    snap_current: np.ndarray  # (snaps,)
    snap_noise: np.ndarray  # (snaps, ns)
    ev_t: np.ndarray  # (MAX_EVENTS,)
    ev_code: np.ndarray
    ev_index: np.ndarray
    ev_value: np.ndarray
    counts: np.ndarray  # int: [0] rows, [1] snapshots, [2] events


def new_record(n_steps: int, k_out: int, k_str: int, nb: int, nr: int, ng: int,
               ns: int) -> Record:
    """Buffers for a run of ``n_steps`` (one row every ``k_out`` steps, one snapshot every
    ``k_str``, plus the last state)."""
    rows = n_steps // k_out + 2
    snaps = n_steps // k_str + 2
    z = np.zeros
    return Record(z(rows), z((rows, 12, nb)), z((rows, 5)), z(snaps), z((snaps, nr)),
                  z((snaps, nr)), z((snaps, nr)), z((snaps, ng)), np.zeros((snaps, ng), np.bool_),
                  z((snaps, nb)), z((snaps, nb)), z(snaps), z((snaps, ns)), z(MAX_EVENTS),
                  np.zeros(MAX_EVENTS, np.int64), np.zeros(MAX_EVENTS, np.int64), z(MAX_EVENTS),
                  np.zeros(3, np.int64))


def new_switches(nb: int, ns: int) -> Switches:
    """Switches with every sling, supply and sensor intact and no disturbance."""
    return Switches(np.ones(nb), np.ones(nb), np.zeros(nb), np.zeros(nb), np.zeros(nb),
                    np.zeros(nb, np.bool_), np.full(nb, math.inf), np.zeros((3, nb)),
                    np.zeros(1), np.zeros((1, ns)), np.zeros((1, 3, nb)),
                    np.full(2, -1, np.int64), np.zeros(nb, np.bool_), np.zeros(nb, np.bool_))


def new_run_state(nr: int, nb: int, ns: int, ng: int, ne: int) -> RunState:
    """A zero state (the loop sets the initial gas, holding force and equilibrium); ``ne``
    the eliminated modes of the recorded rows' static correction."""
    z = np.zeros
    nan = np.nan
    return RunState(
        q=z(nr), v=z(nr), n=z(nb), H=z(ng), sep=z(ng, np.bool_), broken=z(ng, np.bool_),
        release=np.full((2, ng), nan), H_rate=z(ng), b_prev=z(nr), fill=z(nb), opening=z(nb),
        arrival=np.full(nb, nan), z_prev=z(nb), gas_local=z(nb), gas_free=z(nb), vented=z(nb),
        purged=z(nb), vented_free=z(nb), purged_free=z(nb), counters=z(2, np.int64),
        scalars=np.array([0.0, 0.0, nan, nan, 0.0, 0.0]), z=z(nb), zd=z(nb), p=z(nb), V=z(nb),
        w=z(ns), wv=z(ns), line=z(ns), contact=z(ns), active=z(ns, np.bool_),
        last_active=z(ns, np.bool_), point=z(nb), b=z(nr), implicit=z((nr, nr)),
        stiff=z((nr, nr)), damp=z((nr, nr)), meas=z((3, nb)), work=z((6, nr)), ndot=z(nb),
        flow0=z((2, nb)), H_old=z(ng), gap=z(ng), breached=z(nb, np.bool_), row_line=z(ns),
        row_force=z((2, ne)))
