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

from flexlift._jit import jit
from flexlift.ascent.linalg import dot, matvec, matvec_add
from flexlift.ascent.mechanics import accelerations
from flexlift.ascent.state import MAX_EVENTS
from flexlift.physics.gas import purge_flow


@jit
def log_event(rec, t, code, index, value):
    """Append an event (time [s], code, bag or group index or -1, a value)."""
    k = rec.counts[2]
    if k < MAX_EVENTS:
        rec.ev_t[k], rec.ev_code[k], rec.ev_index[k], rec.ev_value[k] = t, code, index, value
        rec.counts[2] = k + 1


@jit
def store_row(t, A, C, S, R, W, rec):
    """One output row of the current state (after :func:`flexlift.ascent.mechanics.
    strip_loads` and the bag forces of this step)."""
    r = rec.counts[0]
    if r >= rec.t.size:
        return
    line = R.line + R.contact
    z = R.z + A.corr_weight  # plus the static correction of the eliminated modes
    matvec_add(A.corr_strip, line, z)
    matvec_add(A.corr_bag, R.point, z)
    slope = matvec(A.bag_slope, R.q, np.empty(A.nb)) + A.slope_weight
    matvec_add(A.slope_strip, line, slope)
    matvec_add(A.slope_bag, R.point, slope)
    rate = matvec(A.bag_slope, R.v, np.empty(A.nb))
    nb = A.nb
    out = rec.bag[r]
    out[:, :] = np.nan
    for i in range(nb):
        fill = R.fill[i] * W.supply[i]
        purge = purge_flow(R.opening[i], R.V[i], A.capacity[i], A.purge_max)
        out[0, i], out[1, i], out[2, i], out[3, i] = z[i], R.zd[i], slope[i], rate[i]
        out[4, i], out[5, i], out[6, i], out[7, i] = fill - purge, R.V[i], R.point[i], fill
    for k in range(C.bags.size):
        i = C.bags[k]
        out[8, i], out[9, i], out[10, i], out[11, i] = (R.opening[i], S.u[k], S.V_d[k],
                                                       S.z_ref[k])
    uplift = 0.0
    for g in range(A.ng):
        uplift += group_uplift(A, R.V, W.attached, g)
    contact = 0.0
    for s in range(A.ns):
        contact += R.contact[s] * A.strip_weight[s]
    rec.hull[r, 0] = dot(A.heave_row, R.q)
    rec.hull[r, 1] = math.atan(dot(A.pitch_row, R.q))
    rec.hull[r, 2] = R.H.sum()
    rec.hull[r, 3] = uplift
    rec.hull[r, 4] = contact
    rec.t[r] = t
    rec.counts[0] = r + 1


@jit
def group_uplift(A, V, attached, g):
    """Net uplift U_g of holding group ``g`` [N]: its bags' buoyancy minus its wet weight."""
    total = 0.0
    for i in range(V.size):
        if A.bag_group[i] == g:
            total += A.rho_g * V[i] * attached[i]
    return total - A.group_weight[g]


@jit
def store_snapshot(t, A, R, W, noise, rec):
    """A strength snapshot of the current state (``noise`` the strip noise of this step)."""
    k = rec.counts[1]
    if k >= rec.snap_t.size:
        return
    rec.snap_t[k] = t
    rec.snap_q[k] = R.q
    rec.snap_v[k] = R.v
    rec.snap_a[k] = accelerations(A, R.q, R.v, R.b, R.contact)
    rec.snap_H[k] = R.H
    rec.snap_sep[k] = R.sep
    rec.snap_V[k] = R.V
    rec.snap_attached[k] = W.attached
    rec.snap_current[k] = W.current[0]
    rec.snap_noise[k] = noise
    rec.counts[1] = k + 1
