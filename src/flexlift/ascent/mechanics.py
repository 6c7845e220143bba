"""The plant's compiled pieces: motion at the bags and strips, the loads from the laws of
:mod:`flexlift.physics`, and the implicit step of the modal mechanics.

Loads on the structure (up positive) at a state:

- bags: buoyancy rho g V at the bag's point (span for internal bags) minus the bag's drag,
  times 1 while its sling holds; V from Boyle at the bag's local pressure, at the surface the
  gas below the waterline of a bag with a surface law (docs/theory/gas.md#surface);
- strips: hull drag on the velocity relative to the current, the force noise, the released
  suction of a separated group H_g shape(x) (down), and the seabed contact, one-sided, or
  tension-capable (bilateral) while the strip's group is held;
- the wet weight (point masses included), a constant generalised force.

Time step of the mechanics y = [q, q']: q'' = -K q - C q' + b, with K = diag(omega^2) + K_c and
C = diag(2 zeta omega) + C_c, where K_c, C_c are the contact springs and dampers of the strips
in contact (implicit, so the stiff seabed penalty is stable at any step) and b every other
generalised force, extrapolated to mid-step (Adams-Bashforth 2): the trapezoidal rule
(Newmark's average acceleration, second order, A-stable). The implicit matrix is cached and
rebuilt only when the set of strips in contact changes, or the step length does.

Each law takes the plant (:class:`~flexlift.ascent.records.PlantRecords`, a struct in the loop)
and reads the part it needs (``bags = plant.bags``, a view: :mod:`flexlift._struct`). Inside
a loop over strips or bags, the arrays it reads are taken once before the loop
(:func:`strip_loads`): read through the struct, each would be found again after every store.
"""

from __future__ import annotations

import numpy as np

from flexlift._jit import inline_jit, jit
from flexlift.ascent.linalg import matvec, matvec_add, matvec_t2
from flexlift.ascent.records import BAG_ENCLOSED, BAG_OPEN_PARACHUTE, BAG_PAPER
from flexlift.physics.gas import ambient_pressure, buoyancy, gas_volume, moles_of
from flexlift.physics.hydro import drag
from flexlift.physics.seabed import contact_load, in_contact
from flexlift.physics.surface import waterline_volume


@inline_jit
def bag_motion(plant, q, v, z, zd):
    """Heights [m] and vertical speeds [m/s] of the bag points (retained modes), into z, zd."""
    bags = plant.bags
    matvec(bags.shape, q, z)
    matvec(bags.shape, v, zd)


@inline_jit
def bag_gas(plant, n, z, p, volume):
    """Ambient pressure [Pa] and gas volume [m^3] of every bag, into p and ``volume`` (at the
    surface the part below the waterline: :func:`lifting_volume`)."""
    bags = plant.bags
    for i in range(n.size):
        p[i] = ambient_pressure(z[i], bags.water_depth, bags.p_atm, bags.rho_g)
        volume[i] = lifting_volume(plant, i, gas_volume(n[i], p[i], bags.RT, bags.capacity[i]), z[i])


@inline_jit
def freeboard(plant, i, z):
    """How far [m] bag ``i``'s top stands above the surface with its point at height ``z``
    [m] (negative: below it)."""
    bags = plant.bags
    return z + bags.top_offset[i] - bags.water_depth


@inline_jit
def lifting_volume(plant, i, volume, z):
    """The part [m^3] of bag ``i``'s gas ``volume`` that displaces water with its point at
    height ``z`` [m]: all of it below the surface; a bag with a surface law (any but
    ``BAG_PAPER``) whose top stands above the surface, its gas below the waterline
    (:func:`flexlift.physics.surface.waterline_volume`)."""
    bags = plant.bags
    if bags.kind[i] == BAG_PAPER:
        return volume
    return waterline_volume(volume, freeboard(plant, i, z), bags.body_diameter[i],
                            bags.body_length[i], bags.cone_top[i], bags.kind[i] != BAG_ENCLOSED)


@inline_jit
def tipped_spill(plant, i, n, p, z):
    """Gas [mol] an open bag spills when it tips: past its tip freeboard an open parachute bag
    (``BAG_OPEN_PARACHUTE``) keeps only its gas below the waterline (``n`` [mol] at the
    ambient ``p`` [Pa], its point at height ``z`` [m]); 0 for any other bag or freeboard."""
    bags = plant.bags
    if bags.kind[i] != BAG_OPEN_PARACHUTE or freeboard(plant, i, z) <= bags.tip_freeboard[i]:
        return 0.0
    keep = lifting_volume(plant, i, gas_volume(n, p, bags.RT, bags.capacity[i]), z)
    return max(n - moles_of(keep, p, bags.RT), 0.0)


@inline_jit
def bag_forces(plant, volume, zd, attached, current, point):
    """Force of every bag on the structure [N], into ``point``: buoyancy minus the bag's drag
    on its speed relative to the ``current`` [m/s], nothing once its sling is broken."""
    bags = plant.bags
    for i in range(volume.size):
        point[i] = (buoyancy(volume[i], bags.rho_g) + drag(zd[i] - current, bags.drag[i])) * attached[i]


@jit
def strip_loads(plant, q, v, holding, sep, current, noise, w, wv, line, contact, active):
    """Strip motion (w [m], wv [m/s]), the explicit line loads (drag, noise, released
    suction) and the contact line loads [N/m], and which strips are in contact (``active``:
    their springs go into the implicit step), with each group's ``holding`` force H [N].
    Returns the lowest strip height [m]."""
    strips = plant.strips
    matvec_t2(strips.shape_t, q, v, w, wv)
    # the plant's arrays taken once: read through the struct inside the loop, each element's
    # array was found again after every store (the compiler cannot tell the outputs from the
    # struct's own memory): a fifth of the loop's time was this function
    group, hold, coeff = strips.group, strips.hold, strips.drag
    stiffness, damping = strips.contact_k, strips.contact_c
    w_min = np.inf
    for s in range(w.size):
        g = group[s]
        held = not sep[g]
        ws, wvs = w[s], wv[s]
        load = drag(wvs - current, coeff[s]) + noise[s]
        if not held:
            load -= holding[g] * hold[s]
        line[s] = load
        if held or ws < 0.0:
            k, c = stiffness[s], damping[s]
            contact[s] = contact_load(ws, wvs, k, c, held)
            active[s] = held or in_contact(ws, wvs, k, c)
        else:  # free and above the seabed (the ascent): the one-sided law's zero, not
            # evaluated (-0.0: added to a line load or a sum it changes nothing, as the
            # law's q x 0 does)
            contact[s] = -0.0
            active[s] = False
        w_min = min(w_min, ws)
    return w_min


@inline_jit
def generalised_force(plant, line, point, b):
    """The explicit generalised force [N] into ``b``: strip line loads, bag forces, weight."""
    b[:] = plant.modal.weight_force
    matvec_add(plant.strips.force, line, b)
    matvec_add(plant.bags.force, point, b)


@jit
def contact_matrices(plant, active, stiff, damp):
    """Modal stiffness and damping [per modal coordinate] of the strips in contact."""
    stiff[:] = 0.0
    damp[:] = 0.0
    for s in range(active.size):
        if active[s]:
            _add_springs(plant, s, 1.0, stiff, damp)


@jit
def update_contact_matrices(plant, active, last, stiff, damp):
    """:func:`contact_matrices` for the pattern ``active`` from those of the pattern ``last``:
    the springs of the strips whose contact changed added or taken away (a moving touchdown
    changes a few strips at a time; rebuilding all of them was most of a staged lift's time)."""
    for s in range(active.size):
        if active[s] != last[s]:
            sign = 1.0 if active[s] else -1.0
            _add_springs(plant, s, sign, stiff, damp)


@jit
def _add_springs(plant, s, sign, stiff, damp):
    """Add ``sign`` times strip ``s``'s contact spring and damper to the modal matrices."""
    strips = plant.strips
    nr = stiff.shape[0]
    for i in range(nr):
        fi = strips.force[i, s] * sign
        if fi == 0.0:
            continue
        for j in range(nr):
            sj = strips.shape[s, j]
            stiff[i, j] += fi * strips.contact_k[s] * sj
            damp[i, j] += fi * strips.contact_c[s] * sj


@jit
def implicit_matrix(plant, h, stiff, damp, out):
    """Inverse of I + h^2/4 K + h/2 C for a step of ``h`` [s], into ``out``."""
    modal = plant.modal
    nr = modal.nr
    M = np.empty((nr, nr))
    for i in range(nr):
        for j in range(nr):
            M[i, j] = 0.25 * h * h * stiff[i, j] + 0.5 * h * damp[i, j]
        M[i, i] += 1.0 + 0.25 * h * h * modal.omega2[i] + 0.5 * h * modal.damping[i]
    out[:] = np.linalg.inv(M)


@inline_jit
def trapezoidal_step(plant, q, v, b_mid, h, implicit, stiff, damp, work):
    """Advance q, q' by ``h`` [s] in place (trapezoidal rule, contact springs implicit, the
    other forces ``b_mid`` taken at mid-step); ``work`` (nr,) scratch."""
    modal = plant.modal
    nr = modal.nr
    for i in range(nr):  # work = h (b - K q - C v) - h^2/2 K v
        s = b_mid[i] - modal.omega2[i] * q[i] - modal.damping[i] * v[i]
        kv = modal.omega2[i] * v[i]
        for j in range(nr):
            s -= stiff[i, j] * q[j] + damp[i, j] * v[j]
            kv += stiff[i, j] * v[j]
        work[i] = h * s - 0.5 * h * h * kv
    for i in range(nr):
        dv = 0.0
        for j in range(nr):
            dv += implicit[i, j] * work[j]
        q[i] += h * v[i] + 0.5 * h * dv
        v[i] += dv


@jit
def accelerations(plant, q, v, b, contact):
    """Modal accelerations [per modal coordinate] at a state: every load, contact included."""
    a = b - plant.modal.omega2 * q - plant.modal.damping * v
    return matvec_add(plant.strips.force, contact, a)
