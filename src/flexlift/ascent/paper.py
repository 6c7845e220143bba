"""The paper's configuration (docs/theory/loop.md#paper-plant) as a plant: every external bag on its own 4-state model.

Each external bag i sees only the unsorted-mdc 4-state model of
:func:`flexlift.dynamics.reduce.paper_bag_model` (the wet hull's two rigid modes at the bag's node; the
flexible modes folded into the feedthrough D) from the vertical force at its node to the
displacement there, with no coupling to the other bags. In the records of
:mod:`flexlift.ascent.records` that is two modal coordinates per bag, one strip per bag (its tributary
length, the hull divided at the midpoints between bag points) and one holding group per bag:

- the force on bag i is its own lift and bag drag, minus its tributary share of the wet
  weight net of the internal bags' constant buoyancy (the internal bags are full and not
  modelled further), of the hull drag and of the suction, plus a seabed spring over its
  tributary length;
- each bag breaks out on its own: its holding force starts at its tributary share of H_0 (in
  the holding shape) and follows docs/theory/seabed.md#suction-held with its own uplift;
- each bag starts neutral on its own model (gas for its tributary share of the net wet
  weight), and its controllers take that as their neutral volume.

The recorded height of a bag adds D times the force on it (the static flexible part); the
"pitch" is the least-squares line through the uncoupled bag heights and means little. The
same compiled loop runs it, with the same laws, faults, noise and current as the coupled plant.
"""

from __future__ import annotations

import numpy as np

from flexlift.ascent.plant import Plant, coupled_plant
from flexlift.ascent.records import Bags, Modal, Seabed, Strips
from flexlift.dynamics.reduce import paper_bag_model


def tributary(x: np.ndarray, length: float) -> tuple[np.ndarray, np.ndarray]:
    """Tributary lengths [m] of points ``x`` [m] on a hull of ``length`` [m] (divided at the
    midpoints between neighbours) and where each tributary starts [m]."""
    order = np.argsort(x)
    edges = np.concatenate([[0.0], 0.5 * (x[order][1:] + x[order][:-1]), [length]])
    trib, lo = np.empty(x.size), np.empty(x.size)
    trib[order], lo[order] = np.diff(edges), edges[:-1]
    return trib, lo


def paper_plant(scenario, coupled: Plant | None = None) -> Plant:
    """The paper's uncoupled plant of ``scenario`` (from its coupled plant, built if not given)."""
    P = coupled or coupled_plant(scenario)
    pb, pstrips, psb = P.bags, P.strips, P.seabed
    ext = np.flatnonzero(P.external)
    ne = ext.size
    models = [paper_bag_model(P.modes, P.hull.nearest_node(P.x_point[i]),
                              zeta=scenario.hull.modal_damping) for i in ext]
    L = P.hull.length
    x = P.x_point[ext]
    trib, lo = tributary(x, L)
    net_weight = P.wet_weight - pb.rho_g * float(pb.capacity[~P.external].sum())
    W = net_weight * trib / L
    stern, bow = P.hold_stern_bow
    from flexlift.physics.seabed import holding_shape

    hold = np.array([holding_shape(np.linspace(s, s + t, 201), L, stern, bow).mean() * t
                     for s, t in zip(lo, trib)])
    H0 = psb.H0[0] * hold / hold.sum()
    nr = 2 * ne
    om2, damp = np.zeros(nr), np.zeros(nr)
    shape, force = np.zeros((ne, nr)), np.zeros((nr, ne))
    D = np.zeros(ne)
    for k, m in enumerate(models):
        sl = slice(2 * k, 2 * k + 2)
        om2[sl], damp[sl] = m.omega**2, 2.0 * m.zeta * m.omega
        shape[k, sl] = m.c_disp[0]
        force[sl, k] = m.b[:, 0]
        D[k] = float(m.D.ravel()[0])
    xc = x - x.mean()
    pitch_row = (xc @ shape) / float(xc @ xc) if ne > 1 else np.zeros(nr)
    eye = np.eye(ne)
    modal = Modal(nr=nr, omega2=om2, damping=damp, weight_force=-(force @ W),
                  pitch_row=pitch_row, heave_row=shape.mean(axis=0))
    strips = Strips(
        ns=ne, shape=shape.copy(), shape_t=np.ascontiguousarray(shape.T),
        force=force * trib[None, :], weight=trib.copy(),
        drag=np.full(ne, pstrips.drag[0]), contact_k=np.full(ne, pstrips.contact_k[0]),
        contact_c=np.full(ne, pstrips.contact_c[0]), group=np.arange(ne, dtype=np.int64),
        hold=1.0 / trib)
    bags = Bags(
        nb=ne, shape=shape.copy(), slope=np.tile(pitch_row, (ne, 1)), force=force.copy(),
        group=np.arange(ne, dtype=np.int64), capacity=pb.capacity[ext].copy(),
        relief=pb.relief[ext].copy(), kind=pb.kind[ext].copy(),
        body_diameter=pb.body_diameter[ext].copy(), body_length=pb.body_length[ext].copy(),
        cone_top=pb.cone_top[ext].copy(), tip_freeboard=pb.tip_freeboard[ext].copy(),
        top_offset=pb.top_offset[ext].copy(), drag=pb.drag[ext].copy(),
        purge_max=pb.purge_max[ext].copy(), supply_free_air=pb.supply_free_air, RT=pb.RT, p_atm=pb.p_atm,
        rho_g=pb.rho_g,
        water_depth=pb.water_depth, corr_shape=eye, corr_weight=-W * D,
        slope_shape=np.zeros((ne, ne)), slope_weight=np.zeros(ne),
        gen_strip=eye * (D * trib)[:, None], gen_bag=eye * D[:, None], count=np.ones(ne))
    seabed = Seabed(ng=ne, hold_force=-force.copy(), H0=H0, group_weight=W,
                    breakout_time=psb.breakout_time, release_time=psb.release_time,
                    liftoff_clearance=psb.liftoff_clearance, law=psb.law,
                    consolidation_time=psb.consolidation_time)
    return Plant(kind="paper", names=tuple(P.names[i] for i in ext), external=np.ones(ne, bool),
                 x_point=x.copy(), spans=(None,) * ne, neutral_volume=W / pb.rho_g,
                 strip_x=x.copy(), strip_element=P.hull.element_of(x), modal=modal, strips=strips,
                 bags=bags, seabed=seabed, hull=P.hull, modes=P.modes, plan=P.plan,
                 mass_line=P.mass_line, wet_weight=P.wet_weight, hold_stern_bow=P.hold_stern_bow,
                 gravity=P.gravity, seawater_density=P.seawater_density,
                 steel_density=P.steel_density)
