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
from flexlift.ascent.state import MAX_EVENTS
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
    line = state.line + state.contact
    # plus the static correction of the eliminated modes, through their generalised forces
    # (records.Bags: factored, no bags x bags product)
    ne = plant.bags.gen_strip.shape[0]
    f_line = matvec(plant.bags.gen_strip, line, np.empty(ne))
    f_point = matvec(plant.bags.gen_bag, state.point, np.empty(ne))
    z = state.z + plant.bags.corr_weight
    matvec_add(plant.bags.corr_shape, f_line, z)
    matvec_add(plant.bags.corr_shape, f_point, z)
    slope = matvec(plant.bags.slope, state.q, np.empty(plant.bags.nb)) + plant.bags.slope_weight
    matvec_add(plant.bags.slope_shape, f_line, slope)
    matvec_add(plant.bags.slope_shape, f_point, slope)
    rate = matvec(plant.bags.slope, state.v, np.empty(plant.bags.nb))
    nb = plant.bags.nb
    out = recorder.bag[r]
    out[:, :] = np.nan
    for i in range(nb):
        fill = state.fill[i] * switches.supply[i]
        purge = purge_flow(state.opening[i], state.V[i], plant.bags.capacity[i],
                           plant.bags.purge_max[i])
        out[0, i], out[1, i], out[2, i], out[3, i] = z[i], state.zd[i], slope[i], rate[i]
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
def group_uplift(plant, V, attached, g):
    """Net uplift U_g of holding group ``g`` [N]: its bags' buoyancy minus its wet weight
    (a bag standing for ``count`` identical bags counted that many times)."""
    bags = plant.bags
    total = 0.0
    for i in range(V.size):
        if bags.group[i] == g:
            total += bags.rho_g * V[i] * attached[i] * bags.count[i]
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
