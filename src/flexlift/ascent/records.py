"""The plant as the compiled loop reads it: one record per part, and the loop's inputs.

A plant (:mod:`flexlift.ascent.plant`, :mod:`flexlift.ascent.paper`) is four read-only
records of arrays, SI throughout:

- :class:`Modal`: the retained modal coordinates (nr of them) and their mechanics;
- :class:`Strips`: the ``ns`` quadrature points along the structure (its distributed loads:
  drag, seabed contact, released suction);
- :class:`Bags`: the ``nb`` lift bags (their points, the gas in them and the constants of
  its laws, drag, and the static correction of the heights and slopes recorded there);
- :class:`Seabed`: the ``ng`` holding groups of the seabed's suction.

:class:`PlantRecords` holds the four; the compiled loop reads ``plant.bags.capacity``.
:class:`LoopInputs` gathers it with the controllers' and the run's records
(:mod:`flexlift.control.controller`, :mod:`flexlift.ascent.state`): the one argument of the
compiled loop (:mod:`flexlift.ascent.kernel`). Inside the loop each record is a struct
passed as one pointer, as a view that counts no reference (:mod:`flexlift._struct`); the
plant's four records are views inside it (``plant.bags``).

"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

#: ``Bags.kind``: the paper's bags (external bags spill beyond their capacity, internal ones
#: relieve at ``gas.relief_pressure_bar``; no surface law: the run ends at a breach, as before)
BAG_PAPER = 0
#: an open parachute bag: spills from its mouth; at the surface it broaches (lifts its gas below
#: the waterline) and past its tip freeboard tips and spills to that (docs/theory/gas.md#surface)
BAG_OPEN_PARACHUTE = 1
#: a closed parachute bag: relieves at its setting over ambient; at the surface it floats
BAG_CLOSED_PARACHUTE = 2
#: an enclosed bag (a lying cylinder): relieves at its setting; at the surface it floats
BAG_ENCLOSED = 3
#: ``lift.catalogue_bag.type`` -> the kind of the plan's external bags
BAG_KINDS = {"pressurised_cylinder": BAG_PAPER, "open_parachute": BAG_OPEN_PARACHUTE,
             "closed_parachute": BAG_CLOSED_PARACHUTE, "enclosed": BAG_ENCLOSED}
#: an open bag tips once its top stands this fraction of its height above the surface
TIP_FRACTION = 0.25


class Modal(NamedTuple):
    """The retained modal coordinates q [m sqrt(kg)]: q'' + damping q' + omega2 q = Q.

    ========================= =========== ==================================================
    field                     unit        meaning
    ========================= =========== ==================================================
    nr                        -           number of modal coordinates
    omega2 (nr,)              rad^2/s^2   omega^2
    damping (nr,)             1/s         2 zeta omega
    weight_force (nr,)        N           generalised wet weight (point masses included)
    pitch_row (nr,)           rad         the hull's pitch angle per unit q
    heave_row (nr,)           m           heave of the centre of mass per unit q
    ========================= =========== ==================================================
    """

    nr: int
    omega2: np.ndarray
    damping: np.ndarray
    weight_force: np.ndarray
    pitch_row: np.ndarray
    heave_row: np.ndarray


class Strips(NamedTuple):
    """The quadrature points ("strips") along the structure and their loads.

    ========================= =========== ==================================================
    field                     unit        meaning
    ========================= =========== ==================================================
    ns                        -           number of strips
    shape (ns, nr)            m / q       displacement at each strip per unit q
    shape_t (nr, ns)          m / q       the same, transposed (the step's strip motion,
                                          :func:`~flexlift.ascent.linalg.matvec_t2`)
    force (nr, ns)            m           generalised force per unit line load at a strip
    weight (ns,)              m           quadrature weight: line load times it is a force
    drag (ns,)                kg/m^2      hull drag coefficient 1/2 rho C_D B
    contact_k (ns,)           N/m^2       seabed contact stiffness per length
    contact_c (ns,)           N s/m^2     seabed contact damping per length
    group (ns,) int           -           the holding group the strip belongs to
    hold (ns,)                1/m         holding line load per unit H of its group
    ========================= =========== ==================================================
    """

    ns: int
    shape: np.ndarray
    shape_t: np.ndarray
    force: np.ndarray
    weight: np.ndarray
    drag: np.ndarray
    contact_k: np.ndarray
    contact_c: np.ndarray
    group: np.ndarray
    hold: np.ndarray


class Bags(NamedTuple):
    """The lift bags: their points on the structure, their gas and the recorded corrections.

    ========================= =========== ==================================================
    field                     unit        meaning
    ========================= =========== ==================================================
    nb                        -           number of bags
    shape (nb, nr)            m / q       displacement at each bag point per unit q
    slope (nb, nr)            rad / q     slope (local pitch angle) at each bag point per q
    force (nr, nb)            -           generalised force per unit bag force
    group (nb,) int           -           the holding group each bag lifts
    capacity (nb,)            m^3         bag capacity V_max
    relief (nb,)              Pa          over-pressure relief setting (0: open bag)
    kind (nb,) int            -           the bag's type (``BAG_*`` above): its surface law
    body_diameter (nb,)       m           the body's diameter D (a bag with a surface law)
    body_length (nb,)         m           its length: the height of an upright bag, at least
                                          its true capacity over pi D^2 / 4
    cone_top (nb,)            m           height of an upright bag's conical top (0: flat)
    tip_freeboard (nb,)       m           an open bag tips past this freeboard (inf: never)
    top_offset (nb,)          m           height of a bag's top above the hull bottom
    drag (nb,)                kg/m        bag drag coefficient 1/2 rho C_D,bag A
    purge_max (nb,)           m^3/s       each bag's purge valve's largest flow Q_out,max
    supply_free_air           m^3/s       a compressor's free-air delivery shared by the bags
                                          (0: no compressor limit; the commanded fill at depth)
    RT                        J/mol       R T of the gas at the sea's temperature
    p_atm                     Pa          atmospheric pressure
    rho_g                     N/m^3       seawater density times gravity
    water_depth               m           depth of the seabed (the ambient pressure)
    corr_shape (nb, ne)       m / N       static correction of the heights per unit
                                          generalised force of the ne eliminated modes
    corr_weight (nb,)         m           ... of the wet weight
    slope_shape (nb, ne)      rad / N     static correction of the slopes per unit
                                          generalised force of the eliminated modes
    slope_weight (nb,)        rad         ... of the wet weight
    gen_strip (ne, ns)        m           eliminated modes' generalised force per line load
    gen_bag (ne, nb)          -           ... per unit bag force
    count (nb,)               -           identical bags this loop bag stands for (1: one)
    ========================= =========== ==================================================

    The corrections are the eliminated modes' static (mdc) response: they enter the recorded
    heights and slopes, not the mechanics. They are kept factored (the height correction of
    line loads ``line`` and bag forces ``point`` is ``corr_shape @ (gen_strip @ line) +
    corr_shape @ (gen_bag @ point)``), so a recorded row costs O(ne (nb + ns)), not the
    O(nb (nb + ns)) of the dense products (the paper's plant: ``corr_shape`` the identity,
    its gains in ``gen_strip``, ``gen_bag``).

    **Clusters** (:mod:`flexlift.ascent.clusters`): a bag of the compiled loop may stand for
    ``count`` identical bags at one lift point. Its gas, pressure, volume and controller are
    those of one member; what acts on the structure is the members' sum: the columns of
    ``force`` and ``gen_bag`` (:data:`BAG_COLUMNS`) are scaled by ``count``, and sums over
    the bags (the groups' uplift, the compressor's demand) weight each bag by ``count``.
    A plant's own record (:class:`flexlift.ascent.plant.Plant`) has one bag per bag:
    ``count`` all 1. A field added here is per bag when its first axis runs over the bags
    (bags that differ in it then never share a loop bag, with no change elsewhere); one whose
    last axis does (a generalised force per unit bag force) goes into :data:`BAG_COLUMNS`.
    """

    nb: int
    shape: np.ndarray
    slope: np.ndarray
    force: np.ndarray
    group: np.ndarray
    capacity: np.ndarray
    relief: np.ndarray
    kind: np.ndarray
    body_diameter: np.ndarray
    body_length: np.ndarray
    cone_top: np.ndarray
    tip_freeboard: np.ndarray
    top_offset: np.ndarray
    drag: np.ndarray
    purge_max: np.ndarray
    supply_free_air: float
    RT: float
    p_atm: float
    rho_g: float
    water_depth: float
    corr_shape: np.ndarray
    corr_weight: np.ndarray
    slope_shape: np.ndarray
    slope_weight: np.ndarray
    gen_strip: np.ndarray
    gen_bag: np.ndarray
    count: np.ndarray


#: the fields of :class:`Bags` whose last axis runs over the bags: generalised forces per unit
#: bag force (a cluster's column is its members' sum). Every other array field whose first
#: axis has ``nb`` entries is per bag along that axis, except those of :data:`NOT_PER_BAG`.
BAG_COLUMNS = ("force", "gen_bag")
#: array fields of :class:`Bags` that are not per bag whatever their shape
NOT_PER_BAG = ("gen_strip",)


def bag_axis(name: str, value, nb: int) -> int | None:
    """The axis of field ``name`` of a :class:`Bags` record that runs over its ``nb`` bags
    (None: not a per-bag field): the last for :data:`BAG_COLUMNS`, else the first of an array
    with ``nb`` rows."""
    if not isinstance(value, np.ndarray) or value.ndim == 0 or name in NOT_PER_BAG:
        return None
    if name in BAG_COLUMNS:
        return value.ndim - 1
    return 0 if value.shape[0] == nb else None


class Seabed(NamedTuple):
    """The seabed's hold, split into holding groups (one, or one per stage of a staged lift).

    ========================= =========== ==================================================
    field                     unit        meaning
    ========================= =========== ==================================================
    ng                        -           number of holding groups
    hold_force (nr, ng)       -           generalised force per unit H of a group (down)
    H0 (ng,)                  N           initial holding force
    group_weight (ng,)        N           wet weight W_g a group's bags must lift
    breakout_time             s           T_b (the timer law)
    release_time              s           tau_r
    liftoff_clearance         m           the structure is clear of the seabed above this
    law                       -           the held law: physics.seabed.LAW_TIMER or LAW_SOIL
    consolidation_time        s           T_c = d^2 / c_v (the soil law)
    ========================= =========== ==================================================
    """

    ng: int
    hold_force: np.ndarray
    H0: np.ndarray
    group_weight: np.ndarray
    breakout_time: float
    release_time: float
    liftoff_clearance: float
    law: int
    consolidation_time: float


class PlantRecords(NamedTuple):
    """The plant's records, as the compiled loop reads them (``plant.strips.shape``)."""

    modal: Modal
    strips: Strips
    bags: Bags
    seabed: Seabed


class LoopInputs(NamedTuple):
    """Everything the compiled loop reads and writes, by name.

    ============== ======================================= ==================================
    field          record                                  changes
    ============== ======================================= ==================================
    plant          :class:`PlantRecords`                   read only
    controllers    control.controller.ControlArrays        read only
    control_state  control.controller.ControlState         the controllers' memory
    state          ascent.state.RunState                   every step
    switches       ascent.state.Switches                   faults, noise (between calls)
    settings       ascent.state.Settings                   read only
    recorder       ascent.state.Record                     rows, snapshots, events
    ============== ======================================= ==================================
    """

    plant: PlantRecords
    controllers: NamedTuple
    control_state: NamedTuple
    state: NamedTuple
    switches: NamedTuple
    settings: NamedTuple
    recorder: NamedTuple
