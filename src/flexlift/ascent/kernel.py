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

Step control (:func:`held_block`): where nothing moves (the pull: every group held, no bag
filling or purging), a block's first step runs as above with the mechanics taken over the
whole block, and its other steps step only the hold and its separation (:func:`quiet_step`).

Faults and noise chunks are set between calls by :mod:`flexlift.ascent.loop`.

**Inputs.** :func:`advance` takes one :class:`~flexlift.ascent.records.LoopInputs` and turns
each of its records into a struct passed by reference (:func:`flexlift._struct.as_struct`):
``plant`` (read only: ``plant.modal``, ``plant.strips``, ``plant.bags``, ``plant.seabed``,
:mod:`flexlift.ascent.records`), ``controllers`` and ``control_state`` (the controllers'
constants and memory, :mod:`flexlift.control.controller`), ``state``, ``switches``,
``settings`` and ``recorder`` (:mod:`flexlift.ascent.state`). Every function here takes, by
these names, the records it reads (the laws of :mod:`flexlift.ascent.mechanics` the plant, and
the state's arrays they work on); the plant's parts are read through it (``plant.bags``).

**Extending the loop** means adding fields and a branch in the function of the law, never a
positional argument:

- *a bag type*: its constants as fields of :class:`~flexlift.ascent.records.Bags` (arrays
  over the bags, with a kind code if the law differs), filled by
  :func:`flexlift.ascent.plant.bag_record` and :func:`flexlift.ascent.paper.paper_plant`;
  the branch on it in the law it changes (``bag_gas``, ``bag_forces`` in mechanics.py,
  ``_gas_step`` here for the gas over a step);
- *a fault*: its switch as a field of :class:`~flexlift.ascent.state.Switches`
  (:func:`~flexlift.ascent.state.new_switches`), set by its branch of
  :func:`flexlift.ascent.faults.apply_fault`, read where it acts (as ``_gas_step`` reads
  ``switches.leak``);
- *a controller*: its constants in :class:`~flexlift.control.controller.ControlArrays`
  (built in :mod:`flexlift.control.build`), its memory in
  :class:`~flexlift.control.controller.ControlState`, its law a function of
  control/controller.py chosen on ``controllers.mode`` in ``observe``/``act``;
- *a loop option*: a field of :class:`~flexlift.ascent.state.Settings` (set in
  :class:`flexlift.ascent.loop.Ascent`), read where it applies;
- *anything that changes inside a quiet block's inner steps* besides the hold (a new law of
  :func:`quiet_step`, or a change made between chunks): clear ``F_STILL`` where it acts, as
  :meth:`flexlift.ascent.loop.Ascent._fault` does; the later inner steps take the step's
  start as the first inner step left it (:func:`quiet_step`);
- *a new kind of record*: a field of ``LoopInputs``, its struct in ``_structs`` and its view
  in ``_views``, and a parameter of only the functions that read it (a new part of the plant
  is a field of ``PlantRecords``, read as ``plant.part``). Below the entry points every
  struct is a view (:func:`flexlift._struct.view`) and a struct inside one is a view too, so
  passing or reading one counts no reference; the arrays inside are borrowed and cost
  nothing either (before the views, the reference counts of the structs were 12 % of the
  loop, measured with ``perf``);
- *a small law called at every step* (a few dozen operations on the loop's arrays), or *a
  part of the step called from one place*: ``@inline_jit`` (:func:`flexlift._jit.
  inline_jit`), compiled into its caller. A call between compiled functions took a
  reference on every struct it passed (an atomic count each) before the views: the step's
  parts inlined (``control``, ``events``, ``finish_step``, the gas step, the rates) took a
  tanker step from 1.95 to 1.75 µs, the first compile from 70 to 85 s. A large function
  called from several places (the strip loads, the implicit step) stays a call, and so does
  ``step`` (inlined into ``_advance`` it made the compile 106 s, for nothing measurable).

Renaming or removing a record's class leaves numba's on-disk cache index naming the old
class: delete the ``*.nbi``/``*.nbc`` files of ``__pycache__`` after such a change.
"""

from __future__ import annotations

import math

import numpy as np
from numba.typed import List

from flexlift._jit import inline_jit, jit
from flexlift._struct import as_struct, view
from flexlift.ascent.linalg import dot
from flexlift.ascent.mechanics import (
    bag_forces,
    bag_gas,
    bag_motion,
    contact_matrices,
    generalised_force,
    implicit_matrix,
    lifting_volume,
    strip_loads,
    tipped_spill,
    trapezoidal_step,
    update_contact_matrices,
)
from flexlift.ascent.recording import group_uplift, log_event, store_row, store_snapshot  # noqa: F401
from flexlift.ascent.records import BAG_PAPER
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
    F_HELD,
    F_LIFTOFF,
    F_LIMIT_D,
    F_LIMIT_P,
    F_LIMIT_V,
    F_MATRIX,
    F_OBSERVED,
    F_QUIET,
    F_RESETTLE,
    F_STILL,
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
def advance(loop, k_stop):
    """Run steps until step ``k_stop`` (exclusive), the end, or a stop; returns why
    (``RET_DONE``: reached k_stop or the last step, ``RET_STOP``, ``RET_NEED_U``). ``loop``
    is a :class:`~flexlift.ascent.records.LoopInputs`; inside, its records are passed by
    reference (:func:`flexlift._struct.as_struct`)."""
    return _advance(_structs(loop), k_stop)


@jit
def advance_many(loops, k_stops, codes):
    """:func:`advance` for several runs in one compiled call: run ``i`` of ``loops`` (a numba
    typed List of :class:`~flexlift.ascent.records.LoopInputs` of one numba type) to step
    ``k_stops[i]``; ``codes[i]`` its return code. An ensemble or a batch of candidates pays
    one entry (its records' types checked once) for all its members, not one each
    (:mod:`flexlift.ascent.batch`)."""
    for i in range(len(loops)):
        codes[i] = _advance(_structs(loops[i]), k_stops[i])


@jit
def loops_of(first):
    """A numba typed List of loop inputs holding ``first``, for :func:`advance_many`, made in
    compiled code: made from Python (``List.empty_list`` and its ``append``), numba compiled
    the list's methods for the inputs' type afresh in every process (about 6 s at the first
    call; numba caches them nowhere), where this function is cached with the loop."""
    out = List()
    out.append(first)
    return out


@jit
def loops_append(loops, item):
    """``item`` appended to a List of :func:`loops_of` (compiled and cached as it is)."""
    loops.append(item)


@jit
def _structs(loop):
    """The records of ``loop`` as structs, in the order of :class:`LoopInputs`: each entry
    point holds them (an argument of its inner function) while the step works on views."""
    return (as_struct(loop.plant), as_struct(loop.controllers), as_struct(loop.control_state),
            as_struct(loop.state), as_struct(loop.switches), as_struct(loop.settings),
            as_struct(loop.recorder))


@inline_jit
def _views(owned):
    """Views of the structs ``owned`` (:func:`flexlift._struct.view`: passed and read with
    no reference counted), in the same order; valid while the caller holds ``owned``: the
    functions that take ``owned`` as an argument (``_advance``, ``_initial_equilibrium``,
    ``_final_row``) stay calls, never inlined."""
    return (view(owned[0]), view(owned[1]), view(owned[2]), view(owned[3]), view(owned[4]),
            view(owned[5]), view(owned[6]))


@jit
def initial_equilibrium(loop):
    """The loads of the state in ``loop.state`` (:class:`LoopInputs`), and the modal
    coordinates at rest on the held seabed springs under them (least squares: the paper's
    bag models have a mode that their one spring does not hold)."""
    _initial_equilibrium(_structs(loop))


@jit
def _initial_equilibrium(owned):
    plant, controllers, control_state, state, switches, settings, recorder = _views(owned)
    bag_motion(plant, state.q, state.v, state.z, state.zd)
    bag_gas(plant, state.n, state.z, state.p, state.V)
    _loads_at_state(plant, state, switches, switches.noise[0])
    contact_matrices(plant, state.active, state.stiff, state.damp)
    K = state.stiff.copy()
    for i in range(plant.modal.nr):
        K[i, i] += plant.modal.omega2[i]
    state.q[:] = np.linalg.lstsq(K, state.b)[0]


@jit
def final_row(t, loop):
    """A recorded row of the current state (:class:`LoopInputs`), at the end of a run."""
    _final_row(t, _structs(loop))


@jit
def _final_row(t, owned):
    plant, controllers, control_state, state, switches, settings, recorder = _views(owned)
    store_row(t, plant, controllers, control_state, state, switches, recorder)


@jit
def _advance(owned, k_stop):
    plant, controllers, control_state, state, switches, settings, recorder = _views(owned)
    while state.counters[0] < k_stop:
        code = step(plant, controllers, control_state, state, switches, settings, recorder)
        if code != RET_DONE:
            return code
        if state.counters[0] > settings.n_steps:
            return RET_DONE
    return RET_DONE


@jit
def step(plant, controllers, control_state, state, switches, settings, recorder):
    """One time step (module docstring); returns RET_DONE to go on."""
    k = state.counters[0]
    t = k * settings.dt
    if (state.counters[1] & F_QUIET and k % settings.held_steps != 0
            and k % settings.k_str != 0 and k != settings.n_steps):
        return quiet_step(t, k, plant, state, switches, settings, recorder)
    state.counters[1] &= ~F_STILL
    if not state.counters[1] & F_FRESH:  # the bags' motion and gas of this state, once
        bag_motion(plant, state.q, state.v, state.z, state.zd)
        bag_gas(plant, state.n, state.z, state.p, state.V)
        state.counters[1] |= F_FRESH
    # the control samples once per quiet block, at its first step (a strength snapshot's
    # step inside the block runs the whole step but its sample: the commands stay held)
    # each modulus once (an integer division is ~15 ns; every step took six)
    row, snap = k % settings.k_out == 0, k % settings.k_str == 0
    sample = ((settings.k_ctrl == 1 or k % settings.k_ctrl == 0)
              and not (state.counters[1] & F_QUIET and k % settings.held_steps != 0))
    if sample and control(t, k, plant, controllers, control_state, state, switches,
                          settings) == RET_NEED_U:
        return RET_NEED_U
    noise = switches.noise[k - switches.chunk[0]] if switches.chunk[0] >= 0 else switches.noise[0]
    cur = switches.current[0]
    bag_forces(plant, state.V, state.zd, switches.attached, cur, state.point)
    held = held_block(t, k, plant, controllers, control_state, state, switches, settings)
    if held > 0:
        state.counters[1] |= F_QUIET
    elif held < 0:
        state.counters[1] &= ~F_QUIET
    if held != 0 or row or snap:
        w_min = strip_loads(plant, state.q, state.v, state.H, state.sep, cur, noise, state.w,
                            state.wv, state.line, state.contact, state.active)
        generalised_force(plant, state.line, state.point, state.b)
    else:  # inside a held block: the structure's loads wait for the block's next step
        w_min = state.w.min()
    if row:
        store_row(t, plant, controllers, control_state, state, switches, recorder)
    if snap:
        store_snapshot(t, plant, state, switches, noise, recorder)
    if events(t, plant, state, switches, settings, recorder, w_min) != RET_DONE:
        return RET_STOP
    if k == settings.n_steps:
        state.counters[0] = k + 1
        return RET_STOP
    step_start(plant, state, switches)
    if held > 0:
        held_mechanics(plant, state, held * settings.dt)
    elif held < 0:
        mechanics(plant, state, switches, settings, w_min, noise)
    finish_step(t, plant, state, switches, settings, recorder, noise)
    return next_step(t, k, state, settings, recorder)


@inline_jit
def held_block(t, k, plant, controllers, control_state, state, switches, settings):
    """Step control where nothing moves: the pull, every holding group held and the bags
    neither filling nor purging, while the hold decays to separation (about 45 % of the
    tanker's simulated time). The structure sits on its bilateral seabed springs, so its
    mechanics advance once every ``settings.held_steps`` base steps (a block: one step of the
    block's length taken at its first step, :func:`held_mechanics`); the block's other steps
    change nothing but the hold (:func:`quiet_step`: the holding force and separation stay on
    every base step, so separation is still located inside its step). Returns the block's
    length in base steps at a block's first step, 0 at its other steps, -1 for a base step.
    A block starts only on a multiple of ``held_steps`` (the recorded rows' steps, when it
    divides ``k_out``) with no group separated, no force noise, the block quiet
    (:func:`quiet_block`) and every group's uplift below its hold by more than
    ``settings.held_margin`` H_0; a separation inside a block ends it. The fill runs in base
    steps: when a bag stops filling decides the gas of the whole lift, and a block would move
    it. Switching between blocks and base steps restarts the force extrapolation (the step
    length changes)."""
    m = settings.held_steps
    flags = state.counters[1]
    if m <= 1:
        return -1
    if flags & F_HELD and k % m != 0 and not state.sep.any():
        return 0
    start = (not state.sep.any() and k % m == 0 and switches.chunk[0] < 0
             and quiet_block(t, m, plant, controllers, control_state, state, switches, settings))
    if start:
        for g in range(plant.seabed.ng):
            gap = group_uplift(plant, state.V, switches.attached, g) - state.H[g]
            if gap >= -settings.held_margin * plant.seabed.H0[g]:
                start = False
                break
    if start != bool(flags & F_HELD):
        state.counters[1] = (flags ^ F_HELD) & ~F_HAVE_B
    return m if start else -1


@inline_jit
def quiet_block(t, m, plant, controllers, control_state, state, switches, settings):
    """Whether a held block of ``m`` base steps may start now (:func:`held_block`): after this
    step's control sample no bag fills or purges, none leaks, no purge controller has an
    integral that could open its valve, no staged bag starts within the block, and the
    sensors have no noise, drift or freeze. Then nothing but the hold changes over the
    block's inner steps (its mechanics taken at its first step, the bags' heights, pressures
    and gas stay put); the commands of this sample are held over the block (the control
    sampled once per block, on measurements that do not change). A spill or relief vent at
    the first step's end (:func:`finish_step`) or a separation (:func:`separations`) sends the
    block's other steps through the whole step (``F_QUIET`` cleared); a fault ends the block
    (:meth:`flexlift.ascent.loop.Ascent._fault`)."""
    if switches.chunk[1] >= 0:  # measurement noise: every sample differs
        return False
    for i in range(plant.bags.nb):
        if (state.fill[i] != 0.0 or state.opening[i] != 0.0 or switches.leak[i] != 0.0
                or switches.drift[i] != 0.0 or switches.frozen[i]):
            return False
    t_end = t + m * settings.dt
    for j in range(controllers.bags.size):
        if control_state.integ[j] > 0.0:
            return False
        if not control_state.started[j] and controllers.start[j] - 1e-9 <= t_end:
            return False
    return True


@inline_jit
def quiet_step(t, k, plant, state, switches, settings, recorder):
    """An inner step of a quiet held block (:func:`quiet_block`): the events of the state, the
    rates at the step's start, the holding force and separation (:func:`holding`); nothing
    else moves. A separation ends the quiet (its step redone as every separation is).

    After the block's first inner step (``F_STILL``: the step before was an inner step, and
    any other step clears the flag) nothing that step's start read has changed but the hold:
    the events of the same bags' heights log nothing new, and the bags' rates, the heights
    and q, q' kept for the step's end are those already kept, to the bit; only the hold's
    part of the start (:func:`hold_start`) is taken again (a tanker's pull: ~0.1 of its
    ~0.11 microseconds a step went to the rest)."""
    if state.counters[1] & F_STILL:
        hold_start(plant, state, switches)
    else:
        # no group is separated (a separation ends the quiet, :func:`separations`): events
        # reads no clearance (w_min) before one is
        if events(t, plant, state, switches, settings, recorder, 0.0) != RET_DONE:
            return RET_STOP
        step_start(plant, state, switches)
        state.counters[1] |= F_STILL
    holding(t, plant, state, switches, settings, recorder, switches.noise[0])
    return next_step(t, k, state, settings, recorder)


@inline_jit
def step_start(plant, state, switches):
    """What the step's end reads of its start: the rates (:func:`rates`), the heights (for
    the arrivals' interpolation), q and q' (a separation redoes the step from them)."""
    rates(plant, state, switches)
    state.z_prev[:] = state.z
    state.work[4] = state.q
    state.work[5] = state.v


@inline_jit
def next_step(t, k, state, settings, recorder):
    """On to step k + 1; every 100 steps the state checked (RET_STOP when it is not finite
    or has blown up)."""
    state.counters[0] = k + 1
    if k % 100 == 0 and not healthy(state):
        log_event(recorder, t + settings.dt, EV_NUMERICS, -1, 0.0)
        return RET_STOP
    return RET_DONE


@inline_jit
def control(t, k, plant, controllers, control_state, state, switches, settings):
    """A control sample: measure, observe, supervise, act; RET_NEED_U when the supervisor is
    evaluated outside (its inputs are then in ``control_state.e_in``, ``.r_in``; call again
    with ``control_state.u`` set)."""
    if not state.counters[1] & F_OBSERVED:
        measure(t, k, plant, state, switches, settings)
        for j in range(controllers.bags.size):
            i = controllers.bags[j]
            control_state.in_z[j], control_state.in_zd[j] = state.meas[0, i], state.meas[1, i]
            control_state.in_sep[j] = state.sep[plant.bags.group[i]]
        observe(t, control_state.in_z, control_state.in_zd, control_state.in_sep, controllers,
                control_state)
        if settings.external:
            state.counters[1] |= F_OBSERVED
            return RET_NEED_U
        supervise(controllers, control_state)
    state.counters[1] &= ~F_OBSERVED
    for j in range(controllers.bags.size):
        control_state.in_V[j] = state.meas[2, controllers.bags[j]]
    act(control_state.in_V, controllers, control_state)
    for j in range(controllers.bags.size):
        i = controllers.bags[j]
        state.fill[i], state.opening[i] = control_state.fill[j], control_state.opening[j]
    stuck_valves(controllers, state, switches)
    supply_limit(plant, state, switches)
    return RET_DONE


@inline_jit
def stuck_valves(controllers, state, switches):
    """Stuck valves override the commands of every bag (controlled or not): a dump valve
    stuck closed purges nothing; a fill valve stuck open fills at the full rate
    ``controllers.fill_max`` [m^3/s at local pressure] whatever the command (the gas beyond
    the bag's true capacity then spills or is relieved, at the end of the step)."""
    for i in range(state.fill.size):
        if switches.dump_stuck[i]:
            state.opening[i] = 0.0
        if switches.fill_stuck[i]:
            state.fill[i] = controllers.fill_max


@inline_jit
def supply_limit(plant, state, switches):
    """The compressor's share: when the bags being filled ask for more free air than its
    delivery Q_fad (``plant.bags.supply_free_air`` > 0), every fill is scaled down alike so that
    sum(fill_i p_i / p_atm) = Q_fad; each bag then fills at its share times p_atm / p_i at its
    depth (docs/theory/gas.md#supply). Held until the next control sample, like the command.
    A bag standing for ``count`` identical bags asks for that many shares."""
    bags = plant.bags
    if bags.supply_free_air <= 0.0:
        return
    demand = 0.0
    for i in range(bags.nb):
        p = ambient_pressure(state.z[i], bags.water_depth, bags.p_atm, bags.rho_g)
        demand += state.fill[i] * switches.supply[i] * p / bags.p_atm * bags.count[i]
    if demand > bags.supply_free_air:
        scale = bags.supply_free_air / demand
        for i in range(bags.nb):
            state.fill[i] *= scale


@inline_jit
def measure(t, k, plant, state, switches, settings):
    """What the sensors report, into state.meas (3, nb): height, speed and gas volume with drift,
    noise and stuck or dropped-out sensors (which repeat their last values)."""
    j = k // settings.k_ctrl - switches.chunk[1]
    noisy = switches.chunk[1] >= 0
    for i in range(plant.bags.nb):
        zm = state.z[i] + switches.drift[i] * max(t - switches.drift_t0[i], 0.0)
        zdm, Vm = state.zd[i], state.V[i]
        if noisy:
            zm += switches.meas_noise[j, 0, i]
            zdm += switches.meas_noise[j, 1, i]
            Vm += switches.meas_noise[j, 2, i]
        if switches.frozen[i] and t >= switches.frozen_until[i]:
            switches.frozen[i] = False
        if switches.frozen[i]:
            zm, zdm, Vm = switches.last[0, i], switches.last[1, i], switches.last[2, i]
        switches.last[0, i], switches.last[1, i], switches.last[2, i] = zm, zdm, Vm
        state.meas[0, i], state.meas[1, i], state.meas[2, i] = zm, zdm, Vm


@inline_jit
def events(t, plant, state, switches, settings, recorder, w_min):
    """The events of the current state; RET_STOP ends the run: the target held; a breach of
    one of the paper's bags (no surface law); after a breach, the structure resettled."""
    for i in range(plant.bags.nb):
        if (switches.attached[i] > 0.0 and state.z[i] > settings.top_limit[i]
                and not state.breached[i]):
            state.breached[i] = True
            log_event(recorder, t, EV_SURFACE_BREACH, i, state.z[i])
            if plant.bags.kind[i] == BAG_PAPER:
                return RET_STOP
    if not state.sep.any():
        return RET_DONE
    limits(t, plant, state, switches, settings, recorder)
    flags = state.counters[1]
    if state.sep.all() and not flags & F_RESETTLE:
        if not flags & F_LIFTOFF and w_min > plant.seabed.liftoff_clearance:
            state.counters[1] |= F_LIFTOFF
            log_event(recorder, t, EV_LIFTOFF, -1, w_min)
        elif flags & F_LIFTOFF and w_min < 0.0:
            state.counters[1] |= F_RESETTLE
            log_event(recorder, t, EV_RESETTLE, -1, w_min)
            if state.breached.any():  # broached, spilled and fallen back: the run ends
                return RET_STOP
    return arrivals(t, plant, state, switches, settings, recorder)


@inline_jit
def limits(t, plant, state, switches, settings, recorder):
    """Running maxima of the bags' upward and downward speeds and of the pitch, and their
    limit events (once each)."""
    up, down, i_up, i_down = 0.0, 0.0, -1, -1
    for i in range(plant.bags.nb):
        s = state.zd[i] * switches.attached[i]
        if s > up:
            up, i_up = s, i
        elif -s > down:
            down, i_down = -s, i
    peak(t, state, recorder, 0, up, settings.v_limit, F_LIMIT_V, EV_LIMIT_VELOCITY, i_up)
    peak(t, state, recorder, 4, down, settings.v_down_limit, F_LIMIT_D, EV_LIMIT_DESCENT,
         i_down)
    # the pitch's arc tangent only when its |tan| is the largest yet: atan is odd and
    # monotonic, so the largest pitch and the step it first passes the limit are the same
    # (glibc's atan is both to the bit; a libm whose atan were not could log the limit a
    # step late: tests/test_step_control.py checks it against every step's own atan)
    slope = abs(dot(plant.modal.pitch_row, state.q))
    if slope > state.scalars[5]:
        state.scalars[5] = slope
        peak(t, state, recorder, 1, math.atan(slope), settings.pitch_limit, F_LIMIT_P,
             EV_LIMIT_PITCH, -1)


@inline_jit
def peak(t, state, recorder, slot, value, limit, flag, code, index):
    """A running maximum: ``value`` kept in ``state.scalars[slot]`` when it is the largest
    yet, and the first time it passes ``limit`` the event ``code`` logged (bag ``index``, or
    -1) with it, once (the flag ``flag``)."""
    if value > state.scalars[slot]:
        state.scalars[slot] = value
        if value > limit and not state.counters[1] & flag:
            state.counters[1] |= flag
            log_event(recorder, t, code, index, value)


@inline_jit
def arrivals(t, plant, state, switches, settings, recorder):
    """First arrivals within the tolerance (interpolated inside the step) and the hold."""
    lo, hi = settings.target - settings.tol, settings.target + settings.tol
    if state.z.max() < lo:
        state.scalars[2] = np.nan
        return RET_DONE
    held = True
    for i in range(plant.bags.nb):
        within = abs(state.z[i] - settings.target) <= settings.tol
        if within and math.isnan(state.arrival[i]):
            a, b = state.z_prev[i], state.z[i]
            edge = lo if a < lo else (hi if a > hi else np.nan)
            ta = t
            if not math.isnan(edge) and a != b:
                ta = t - settings.dt + settings.dt * min(max((edge - a) / (b - a), 0.0), 1.0)
            state.arrival[i] = ta
            log_event(recorder, ta, EV_ARRIVAL, i, state.z[i])
        held = held and (within or switches.attached[i] == 0.0)
    if not held:
        state.scalars[2] = np.nan
        return RET_DONE
    if math.isnan(state.scalars[2]):
        state.scalars[2] = t
    if t - state.scalars[2] >= settings.hold_time - 1e-9:
        log_event(recorder, t, EV_TARGET_HELD, -1, settings.hold_time)
        return RET_STOP
    return RET_DONE


@inline_jit
def rates(plant, state, switches):
    """Gas rates [mol/s] at the start of the step into state.ndot, the pressures and purge flows
    into state.flow0; the holding forces and uplift-minus-hold gaps at the start into state.H_old,
    state.gap."""
    for i in range(plant.bags.nb):
        fill = state.fill[i] * switches.supply[i]
        purge = _purge(plant, i, state.opening[i], state.V[i])
        state.ndot[i] = (moles_rate(state.p[i], fill, purge, plant.bags.RT)
                         - switches.leak[i] * state.n[i])
        state.flow0[0, i], state.flow0[1, i] = state.p[i], purge
    hold_start(plant, state, switches)


@inline_jit
def hold_start(plant, state, switches):
    """The holding forces and uplift-minus-hold gaps at the start of the step into
    state.H_old, state.gap (:func:`rates`)."""
    for g in range(plant.seabed.ng):
        state.H_old[g] = state.H[g]
        state.gap[g] = group_uplift(plant, state.V, switches.attached,
                                    g) - state.H[g]


@inline_jit
def _purge(plant, i, opening, volume):
    """Bag ``i``'s purge flow [m^3/s] at valve ``opening`` with gas ``volume`` [m^3]
    (:func:`flexlift.physics.gas.purge_flow`): a closed valve's is exactly 0 (the law's
    0 x Q_max x sqrt(V / V_max)) without its division and square root."""
    if opening <= 0.0:
        return 0.0
    return purge_flow(opening, volume, plant.bags.capacity[i], plant.bags.purge_max[i])


@jit
def mechanics(plant, state, switches, settings, w_min, noise):
    """Advance the modal mechanics over the step (sub-steps near the seabed once free); the
    explicit force is extrapolated to mid-step from the previous step's (or sub-step's)."""
    dt = settings.dt
    have_b = state.counters[1] & F_HAVE_B
    b_mid, b_old, b_start = state.work[0], state.work[1], state.work[2]
    if state.sep.any() and w_min < plant.seabed.liftoff_clearance:
        h = dt / CONTACT_SUBSTEPS
        b_start[:] = state.b
        for i in range(plant.modal.nr):
            b_old[i] = (state.b[i] - (state.b[i] - state.b_prev[i]) * (h / dt) if have_b
                        else state.b[i])
        for j in range(CONTACT_SUBSTEPS):
            if j:
                _loads_at_state(plant, state, switches, noise)
            for i in range(plant.modal.nr):
                b_mid[i] = 1.5 * state.b[i] - 0.5 * b_old[i]
                b_old[i] = state.b[i]
            _implicit_step(plant, state, h, b_mid)
        state.b_prev[:] = b_start
    else:
        for i in range(plant.modal.nr):
            b_mid[i] = 1.5 * state.b[i] - 0.5 * state.b_prev[i] if have_b else state.b[i]
        _implicit_step(plant, state, dt, b_mid)
        state.b_prev[:] = state.b
    state.counters[1] |= F_HAVE_B


@jit
def held_mechanics(plant, state, h):
    """The mechanics over a held block of ``h`` [s] (:func:`held_block`): one backward Euler
    step (L-stable: the stiff held seabed springs do not ring at the block's length, as they
    would under the trapezoidal rule) with the explicit force extrapolated to the block's end
    from the previous block's, which makes it exact while the loads change linearly."""
    b_end = state.work[0]
    have_b = state.counters[1] & F_HAVE_B
    for i in range(plant.modal.nr):
        b_end[i] = 2.0 * state.b[i] - state.b_prev[i] if have_b else state.b[i]
    _implicit_matrix(plant, state, 2.0 * h)  # inverse of I + h C + h^2 K
    backward_euler_step(plant, state.q, state.v, b_end, h, state.implicit, state.stiff,
                        state.damp, state.work[3])
    state.b_prev[:] = state.b
    state.counters[1] |= F_HAVE_B


@jit
def backward_euler_step(plant, q, v, b_end, h, implicit, stiff, damp, work):
    """Advance q, q' by ``h`` [s] in place by backward Euler (every force but ``b_end``, the
    others' value at the step's end, implicit); ``implicit`` the inverse of I + h C + h^2 K
    (:func:`flexlift.ascent.mechanics.implicit_matrix` of 2 h); ``work`` (nr,) scratch."""
    modal = plant.modal
    nr = modal.nr
    for i in range(nr):  # work = h (b - K q - C v) - h^2 K v
        s = b_end[i] - modal.omega2[i] * q[i] - modal.damping[i] * v[i]
        kv = modal.omega2[i] * v[i]
        for j in range(nr):
            s -= stiff[i, j] * q[j] + damp[i, j] * v[j]
            kv += stiff[i, j] * v[j]
        work[i] = h * s - h * h * kv
    for i in range(nr):
        dv = 0.0
        for j in range(nr):
            dv += implicit[i, j] * work[j]
        v[i] += dv
        q[i] += h * v[i]


@jit
def _loads_at_state(plant, state, switches, noise):
    """The loads of the current (sub-step) state, into ``state``."""
    bag_motion(plant, state.q, state.v, state.z, state.zd)
    bag_gas(plant, state.n, state.z, state.p, state.V)
    bag_forces(plant, state.V, state.zd, switches.attached, switches.current[0],
               state.point)
    strip_loads(plant, state.q, state.v, state.H, state.sep, switches.current[0], noise,
                state.w, state.wv, state.line, state.contact, state.active)
    generalised_force(plant, state.line, state.point, state.b)


@jit
def _implicit_step(plant, state, h, b_mid):
    """One trapezoidal step of ``h`` [s]; the implicit matrix rebuilt when the contact
    pattern or the step length changed (the contact springs of the strips that changed
    added or taken away)."""
    _implicit_matrix(plant, state, h)
    trapezoidal_step(plant, state.q, state.v, b_mid, h, state.implicit, state.stiff,
                     state.damp, state.work[3])


@jit
def _implicit_matrix(plant, state, h):
    """The cached implicit matrix of :func:`_implicit_step` for a step of ``h`` [s], rebuilt
    when the contact pattern or ``h`` changed."""
    valid = bool(state.counters[1] & F_MATRIX)
    changed = not valid
    if valid:
        for s in range(plant.strips.ns):
            if state.active[s] != state.last_active[s]:
                changed = True
                break
    if changed or state.scalars[3] != h:
        if not valid:
            contact_matrices(plant, state.active, state.stiff, state.damp)
        elif changed:
            update_contact_matrices(plant, state.active, state.last_active, state.stiff,
                                    state.damp)
        implicit_matrix(plant, h, state.stiff, state.damp, state.implicit)
        state.last_active[:] = state.active
        state.scalars[3] = h
        state.counters[1] |= F_MATRIX


@inline_jit
def finish_step(t, plant, state, switches, settings, recorder, noise):
    """Gas, venting, holding force, separation and breakout at the end of the step; leaves
    the bags' motion and gas of the new state in ``state`` (fresh for the next step). A group that
    separated inside the step moves freely for the rest of it."""
    dt = settings.dt
    bag_motion(plant, state.q, state.v, state.z, state.zd)
    for i in range(plant.bags.nb):
        n = _gas_step(i, dt, plant, state, switches)
        p = state.p[i]
        # spill, relief venting
        out = vented_moles(n, p, plant.bags.capacity[i], plant.bags.relief[i], plant.bags.RT)
        out += tipped_spill(plant, i, n - out, p, state.z[i])  # an open bag tipped at the surface
        if out > 0.0:
            state.counters[1] &= ~F_QUIET  # a held block venting is not quiet
            n -= out
            state.vented[i] += out * plant.bags.RT / p
            state.vented_free[i] += out * plant.bags.RT / plant.bags.p_atm
        state.n[i], state.p[i] = n, p
        state.V[i] = lifting_volume(plant, i, gas_volume(n, p, plant.bags.RT,
                                                         plant.bags.capacity[i]), state.z[i])
    state.counters[1] |= F_FRESH
    holding(t, plant, state, switches, settings, recorder, noise)


@inline_jit
def holding(t, plant, state, switches, settings, recorder, noise):
    """The holding force at the end of the step (held: Adams-Bashforth 2 on its rate; released:
    exactly), separation located inside the step, and breakout."""
    dt = settings.dt
    for g in range(plant.seabed.ng):
        if state.sep[g]:  # released_holding over one step: H exp(-dt / tau_r), the factor
            state.H[g] = state.H[g] * settings.release_step  # computed once (Settings)
        else:
            # the rate at the start of the step (its uplift, kept in state.gap + state.H_old),
            # stepped by Adams-Bashforth 2 with the previous step's
            rate = holding_rate(state.gap[g] + state.H_old[g], state.H_old[g],
                                plant.seabed.H0[g], plant.seabed)
            prev = state.H_rate[g]
            state.H[g] += dt * (1.5 * rate - 0.5 * prev) if not math.isnan(prev) else dt * rate
            state.H_rate[g] = rate
        state.H[g] = max(state.H[g], 0.0)
    separations(t, plant, state, switches, settings, recorder, noise)
    breakouts(t, plant, state, settings, recorder)


@inline_jit
def _gas_step(i, dt, plant, state, switches):
    """Bag ``i``'s gas [mol] at the end of the step (Heun: the rates at the start and at an
    Euler prediction at the new height, averaged; the commands are held over the step), with
    the accounts of the step's flows; leaves the new pressure in state.p."""
    bags = plant.bags
    fill = state.fill[i] * switches.supply[i]
    p0, purge0 = state.flow0[0, i], state.flow0[1, i]
    p1 = ambient_pressure(state.z[i], bags.water_depth, bags.p_atm, bags.rho_g)
    n_pred = max(state.n[i] + dt * state.ndot[i], 0.0)
    purge1 = _purge(plant, i, state.opening[i], gas_volume(n_pred, p1, bags.RT,
                                                           bags.capacity[i]))
    leak = switches.leak[i]
    ndot1 = moles_rate(p1, fill, purge1, bags.RT) - leak * n_pred
    # the accounts: a flow that is zero over the step adds exactly zero, so it is skipped
    # (most steps neither fill, purge nor leak: their divisions were a tenth of the loop)
    if fill != 0.0:
        state.gas_local[i] += fill * dt
        state.gas_free[i] += 0.5 * (free_air(fill * dt, p0, bags.p_atm)
                                    + free_air(fill * dt, p1, bags.p_atm))
    if purge0 != 0.0 or purge1 != 0.0:
        state.purged[i] += 0.5 * dt * (purge0 + purge1)
        state.purged_free[i] += 0.5 * dt * (free_air(purge0, p0, bags.p_atm)
                                            + free_air(purge1, p1, bags.p_atm))
    if leak != 0.0:
        state.vented[i] += 0.5 * dt * leak * bags.RT * (state.n[i] / p0 + n_pred / p1)
        state.vented_free[i] += (0.5 * dt * leak * bags.RT * (state.n[i] + n_pred)
                                 / bags.p_atm)
    state.p[i] = p1
    return max(state.n[i] + 0.5 * dt * (state.ndot[i] + ndot1), 0.0)


@jit
def separations(t, plant, state, switches, settings, recorder, noise):
    """Held groups whose uplift now exceeds their hold separate, at a time interpolated
    inside the step; the mechanics of the step are then redone, held up to that time and free
    after it (sub-steps)."""
    for g in range(plant.seabed.ng):  # mostly none: no array made at every step
        if not state.sep[g] and group_uplift(plant, state.V, switches.attached, g) > state.H[g]:
            break
    else:
        return
    new = np.zeros(plant.seabed.ng, np.bool_)
    th_min = 1.0
    for g in range(plant.seabed.ng):
        if state.sep[g]:
            continue
        gap = group_uplift(plant, state.V, switches.attached, g) - state.H[g]
        if gap > 0.0:
            g0 = state.gap[g]
            th = min(max(g0 / (g0 - gap), 0.0), 1.0) if g0 <= 0.0 else 0.0
            new[g] = True
            th_min = min(th_min, th)
            log_event(recorder, t + th * settings.dt, EV_SEPARATION, g, gap + state.H[g])
            # held up to the separation, released exactly from it
            H_sep = state.H_old[g] + th * (state.H[g] - state.H_old[g])
            state.H[g] = released_holding(H_sep, (1.0 - th) * settings.dt,
                                          plant.seabed.release_time)
            state.release[0, g], state.release[1, g] = t + th * settings.dt, H_sep
    if not new.any():
        return
    state.q[:] = state.work[4]
    state.v[:] = state.work[5]
    for part, free in ((th_min * settings.dt, False), ((1.0 - th_min) * settings.dt, True)):
        if free:
            state.sep[:] = state.sep | new
        if part <= 0.0:
            continue
        h = part / CONTACT_SUBSTEPS
        for _ in range(CONTACT_SUBSTEPS):
            _loads_at_state(plant, state, switches, noise)
            _implicit_step(plant, state, h, state.b)
    # the suction's load steps in: restart the extrapolation; a held block's quiet ends
    state.counters[1] &= ~(F_HAVE_B | F_QUIET)
    bag_motion(plant, state.q, state.v, state.z, state.zd)
    bag_gas(plant, state.n, state.z, state.p, state.V)


@inline_jit
def breakouts(t, plant, state, settings, recorder):
    """Breakout is complete once every group's released hold is below 0.1 % of its H_0; the
    time is where the exact release from the separation crosses that level."""
    for g in range(plant.seabed.ng):
        thr = COMPLETE_FRACTION * plant.seabed.H0[g]
        if state.sep[g] and not state.broken[g] and state.H[g] <= thr:
            state.broken[g] = True
            t_sep, H_sep = state.release[0, g], state.release[1, g]
            tb = t + settings.dt
            if thr > 0.0 and H_sep > thr:
                tb = t_sep + plant.seabed.release_time * math.log(H_sep / thr)
            if state.broken.all():
                log_event(recorder, tb, EV_BREAKOUT, -1, state.H.sum())


@inline_jit
def healthy(state):
    """False when the state is not finite or has blown up."""
    for i in range(state.q.size):
        if not (abs(state.q[i]) < 1e9 and abs(state.v[i]) < 1e9):
            return False
    for i in range(state.n.size):
        if not math.isfinite(state.n[i]):
            return False
    return True
