"""Recording inside the compiled loop: output rows, strength snapshots and the event log.

A row holds, per bag, the variables of :data:`flexlift.ascent.result.BAG_VARS` (heights and
slopes with the static correction of the eliminated modes) and the hull variables of
:data:`~flexlift.ascent.result.HULL_VARS`; a snapshot holds what the strength along the
structure needs afterwards (:mod:`flexlift.ascent.strength`). Everything is copied into
preallocated buffers.
"""

from __future__ import annotations

import math

import numpy as np

from flexlift._jit import inline_jit, jit
from flexlift.ascent.linalg import dot, matvec, matvec_add
from flexlift.ascent.mechanics import accelerations
from flexlift.ascent.state import F_ROW_LINE, MAX_EVENTS
from flexlift.physics.gas import purge_flow


@jit
def log_event(recorder, t, code, index, value):
    """Append an event (time [s], code, bag or group index or -1, a value)."""
    k = recorder.counts[2]
    if k < MAX_EVENTS:
        recorder.ev_t[k], recorder.ev_code[k] = t, code
        recorder.ev_index[k], recorder.ev_value[k] = index, value
        recorder.counts[2] = k + 1


@jit
def store_row(t, plant, controllers, control_state, state, switches, recorder):
    """One output row of the current state (after :func:`flexlift.ascent.mechanics.
    strip_loads` and the bag forces of this step)."""
    r = recorder.counts[0]
    if r >= recorder.t.size:
        return
    bags, nb = plant.bags, plant.bags.nb
    out = recorder.bag[r]
    out[:, :] = np.nan
    # the line load (explicit plus contact), and the generalised forces of the eliminated
    # modes, into the state's row scratch: a row allocates nothing. The line's forces are
    # the last row's when its line is the last row's to the bit (the pull: the held
    # structure at rest, every row alike; the product was a fifth of a held block's cost)
    line = state.row_line
    same = bool(state.counters[1] & F_ROW_LINE)
    for s in range(line.size):
        value = state.line[s] + state.contact[s]
        same = same and _same_bits(value, line[s])
        line[s] = value
    # plus the static correction of the eliminated modes, through their generalised forces
    # (records.Bags: factored, no bags x bags product); heights, slopes and their rates
    # computed in the row itself
    f_line = state.row_force[0]
    if not same:
        matvec(bags.gen_strip, line, f_line)
        state.counters[1] |= F_ROW_LINE
    f_point = matvec(bags.gen_bag, state.point, state.row_force[1])
    z = out[0]
    for i in range(nb):
        z[i] = state.z[i] + bags.corr_weight[i]
    matvec_add(bags.corr_shape, f_line, z)
    matvec_add(bags.corr_shape, f_point, z)
    slope = matvec(bags.slope, state.q, out[2])
    for i in range(nb):
        slope[i] += bags.slope_weight[i]
    matvec_add(bags.slope_shape, f_line, slope)
    matvec_add(bags.slope_shape, f_point, slope)
    matvec(bags.slope, state.v, out[3])  # the slopes' rates
    for i in range(nb):
        fill = state.fill[i] * switches.supply[i]
        purge = purge_flow(state.opening[i], state.V[i], bags.capacity[i], bags.purge_max[i])
        out[1, i] = state.zd[i]
        out[4, i], out[5, i], out[6, i], out[7, i] = (fill - purge, state.V[i], state.point[i],
                                                      fill)
    for k in range(controllers.bags.size):
        i = controllers.bags[k]
        out[8, i], out[9, i] = state.opening[i], control_state.u[k]
        out[10, i], out[11, i] = control_state.V_d[k], control_state.z_ref[k]
    uplift = 0.0
    for g in range(plant.seabed.ng):
        uplift += group_uplift(plant, state.V, switches.attached, g)
    contact = 0.0
    for s in range(plant.strips.ns):
        contact += state.contact[s] * plant.strips.weight[s]
    recorder.hull[r, 0] = dot(plant.modal.heave_row, state.q)
    recorder.hull[r, 1] = math.atan(dot(plant.modal.pitch_row, state.q))
    recorder.hull[r, 2] = state.H.sum()
    recorder.hull[r, 3] = uplift
    recorder.hull[r, 4] = contact
    recorder.t[r] = t
    recorder.counts[0] = r + 1


@inline_jit
def _same_bits(a, b):
    """Whether floats ``a`` and ``b`` are the same number to the bit (a zero's sign too;
    never a NaN)."""
    return a == b and (a != 0.0 or math.copysign(1.0, a) == math.copysign(1.0, b))


@inline_jit
def group_uplift(plant, volume, attached, g):
    """Net uplift U_g of holding group ``g`` [N]: its bags' buoyancy minus its wet weight
    (a bag standing for ``count`` identical bags counted that many times)."""
    bags = plant.bags
    total = 0.0
    for i in range(volume.size):
        if bags.group[i] == g:
            total += bags.rho_g * volume[i] * attached[i] * bags.count[i]
    return total - plant.seabed.group_weight[g]


@jit
def store_snapshot(t, plant, state, switches, noise, recorder):
    """A strength snapshot of the current state (``noise`` the strip noise of this step)."""
    k = recorder.counts[1]
    if k >= recorder.snap_t.size:
        return
    recorder.snap_t[k] = t
    recorder.snap_q[k] = state.q
    recorder.snap_v[k] = state.v
    recorder.snap_a[k] = accelerations(plant, state.q, state.v, state.b, state.contact)
    recorder.snap_H[k] = state.H
    recorder.snap_sep[k] = state.sep
    recorder.snap_V[k] = state.V
    recorder.snap_attached[k] = switches.attached
    recorder.snap_current[k] = switches.current[0]
    recorder.snap_noise[k] = noise
    recorder.counts[1] = k + 1
