"""The tanker's values on a user's structure: required, derived by a named rule, or assumed.

Every scenario key has a default, and the defaults are the paper's tanker (a 78 m chemical
tanker raised from 350 m). That is right for "the tanker with a change" and wrong for a
user's wreck. So a scenario that **describes its own structure** (it gives any hull
particular of :data:`PARTICULARS`, or a ``pipe:`` section) and does not say
``based_on: tanker`` is completed by the rules of :data:`POLICY` instead of the tanker's
values, key by key:

- **required**: the key must be given; a file without it is refused with one line naming the
  key (an older file that relied on the tanker's value is told, never silently re-planned);
- **derived**: computed from what the file gives, by the rule named beside it (outside the
  rule's validity the key is required);
- **assumed**: a generic engineering value (not the tanker's particular) is used and listed,
  with its reason, among the scenario's ``defaulted`` keys, which the run warns about and the
  report's design basis lists.

A scenario that gives no hull particular and no pipe (an empty hull section, or only the
mesh) is the tanker with overrides, as before; so is any file with ``based_on: tanker``.
Keys not in :data:`POLICY` (physical constants such as gravity, the seawater density, the
numerics' step sizes) are generic defaults, the same for every structure.
"""

from __future__ import annotations

import math

from flexlift import constants as C

__all__ = ["PARTICULARS", "POLICY", "describes_own_structure", "complete_own_structure"]

#: hull keys that describe a particular structure (any one given: the file describes its own)
PARTICULARS = (
    "length_m", "length_between_perpendiculars_m", "breadth_m", "depth_m", "displacement_t",
    "mass_per_length_kg_m", "submerged_weight_t", "bending_stiffness_Nm2", "point_masses",
    "frame_spacing_m", "ballast_tank_frames", "section_modulus_m3",
)

#: Young's modulus of structural steel [Pa], for the EI <-> Z rule
E_STEEL = 2.06e11

#: key -> (policy, the rule, the assumption or why it is required); the tanker's value is the
#: schema's default. ``"required"`` keys may be listed as alternatives "a|b" (one of them).
POLICY: dict[str, tuple[str, str]] = {
    "environment.water_depth_m": ("required", "the site's water depth; the tanker's 350 m is "
                                  "not assumed"),
    "control.target_height_m": ("required", "the height above the seabed to lift to; the "
                                "tanker's 300 m is not assumed"),
    "hull.length_m": ("required", "the structure's length"),
    "hull.breadth_m": ("required", "the breadth: drag, added mass and the bag arrangement"),
    "hull.depth_m": ("required", "the depth: the section's height and the plausibility check"),
    "hull.displacement_t|hull.mass_per_length_kg_m": (
        "required", "the structure's mass (uniform displacement_t, or mass_per_length_kg_m "
        "per element)"),
    "hull.bending_stiffness_Nm2|hull.section_modulus_m3": (
        "required", "the hull girder's stiffness EI or its section modulus Z (the other is "
        "derived)"),
    "hull.bending_stiffness_Nm2": (
        "derived", "EI = E Z D / 2 (steel, E = 206 GPa, neutral axis at mid-depth), from "
        "section_modulus_m3 and depth_m"),
    "hull.section_modulus_m3": (
        "derived", "Z = 2 EI / (E D) (steel, E = 206 GPa, neutral axis at mid-depth), from "
        "bending_stiffness_Nm2 and depth_m"),
    "hull.length_between_perpendiculars_m": ("derived", "not used by the analysis: left "
                                             "empty"),
    "lift.internal_bags": ("derived", "0: no internal bags unless the file places them (the "
                           "tanker's three in its ballast tanks are not assumed)"),
    "hull.frame_spacing_m": ("required", "needed to place internal bags by frame number "
                             "(only with lift.internal_bags > 0)"),
    "hull.ballast_tank_frames": ("required", "the frames the internal bags lie over (only with "
                                 "lift.internal_bags > 0)"),
    "seabed.holding_shape": ("derived", "uniform: no distribution of the suction along the "
                             "structure is known (the tanker's bow-heavy 0.5 -> 1.5 is not "
                             "assumed)"),
    "hull.allowable_stress_MPa": ("assumed", "175 MPa, the permissible hull girder bending "
                                  "stress of mild steel (k = 1)"),
    "hull.modal_damping": ("assumed", "2 % of critical in every flexible mode, typical of a "
                           "steel hull in water"),
    "lift.breakout_factor": ("assumed", "1.3 W': a typical breakout allowance; stiff clay "
                             "may need 2"),
    "seabed.breakout_time_s": ("assumed", "400 s for a full pull to break the suction out "
                               "(soil-dependent: ±100 % per NCEL R-755)"),
    "seabed.release_time_s": ("assumed", "30 s for the suction to release after separation"),
    # the soil breakout law's inputs (docs/theory/breakout-soil.md), listed only under that law
    "seabed.shear_strength_kPa": ("assumed", "3 kPa undrained shear strength at the base: very "
                                  "soft clay or silt"),
    "seabed.embedment_m": ("assumed", "1 m of the hull's bottom below the mudline"),
    "seabed.drainage_length_m": ("assumed", "1 m of pore-water path to the hull's base"),
    "seabed.consolidation_coefficient_m2_s": ("assumed", "5e-5 m2/s, calibrated on the Ehime "
                                              "Maru's breakout time (one case)"),
    "control.breakout_pull_t": ("assumed", "18 % of the suction H0 held as extra buoyancy "
                                "until lift-off (the tanker's plan: 150 t of 835 t)"),
    "gas.fill_rate_max_m3_s": ("assumed", "0.5 m3/s of gas per bag at the bag's depth (a "
                               "compressor's free-air delivery is not stated)"),
    "gas.purge_rate_max_m3_s": ("assumed", "2 m3/s through a bag's dump valve, fully open, "
                                "when the catalogue bag gives no dump_valve_m3_s (its own "
                                "valve is taken: scenario/valves.py)"),
    "hydro.drag_coefficient": ("assumed", "1.2 on the breadth (bluff hull sections 1-2)"),
    "hydro.added_mass_coefficient": ("assumed", "1.0 (a33 = Ca rho pi B^2/4 per length)"),
    "hydro.bag_drag_coefficient": ("assumed", "1.0 on a bag's frontal area"),
    "lift.catalogue_bag": ("derived", "the largest standard open parachute bag <= 50 t "
                           "(flexlift/data/bags.yaml) whose cluster per lift point fits on the "
                           "hull (loads/clusters.py; the tanker's 565 t cylinder is not "
                           "assumed)"),
    "limits.pitch_deg": ("assumed", "2 deg: GL Noble Denton 0027/ND 5.3.2 for a lifted "
                         "object, by analogy (the paper's 15 deg is the built-in tanker's); a "
                         "pipe: no tilt criterion, its bending utilisation governs"),
    # the plan and the controllers' tuning: the paper's, used for every structure; the run's
    # criteria then show whether they hold for this one
    "control.ascent_speed_m_s": ("assumed", "0.2 m/s planned ascent, the paper's"),
    "control.supervisor.error_scale_m": ("assumed", "5 m: the supervisor's full-scale height "
                                         "error, the paper's tuning"),
    "control.supervisor.rate_scale_m_s": ("assumed", "0.1 m/s: the supervisor's full-scale "
                                          "rate, the paper's tuning"),
    "control.purge.kp_1_m3": ("assumed", "the purge PID's gain, tuned on the paper's tanker"),
    "control.coordination.pitch_gain_m3_rad": ("assumed", "the coordinated mode's pitch gain, "
                                               "tuned on the paper's tanker"),
}


#: keys read by one breakout law only (seabed.breakout_law): assumed only under that law
LAW_OF = {"seabed.breakout_time_s": "timer", "seabed.shear_strength_kPa": "soil",
          "seabed.embedment_m": "soil", "seabed.drainage_length_m": "soil",
          "seabed.consolidation_coefficient_m2_s": "soil"}


def _given(data: dict, dotted: str) -> bool:
    node = data
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            return False
        node = node[part]
    return True


def _get(data: dict, dotted: str):
    node = data
    for part in dotted.split("."):
        node = node[part]
    return node


def _set(data: dict, dotted: str, value) -> None:
    *path, last = dotted.split(".")
    node = data
    for part in path:
        if node.get(part) is None:  # an empty section (``lift:`` with nothing under it)
            node[part] = {}
        node = node[part]
    node[last] = value


def describes_own_structure(data) -> bool:
    """Whether the raw scenario mapping describes a structure of its own (module docstring)."""
    if not isinstance(data, dict) or data.get("based_on") == "tanker":
        return False
    if data.get("pipe") is not None:
        return True
    hull = data.get("hull")
    return isinstance(hull, dict) and any(k in hull for k in PARTICULARS)


def _number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def complete_own_structure(data: dict) -> dict:
    """``data`` (a raw scenario of a structure of its own, after a pipe's keys are derived)
    with the derived keys of :data:`POLICY` filled in and every key it derived or assumed
    recorded in ``data["defaulted"]`` (key -> "derived" or "assumed"). Required keys are
    checked after validation (:func:`missing_required`), so a bad value is reported first."""
    given = data.get("defaulted")
    given = {} if given is None else given
    if (not isinstance(given, dict) or not all(isinstance(k, str) for k in given)
            or not isinstance(data.get("hull", {}), dict)):
        return data  # not a mapping of keys (or no hull section): the schema reports it
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
    defaulted = dict(given)
    hull = out.setdefault("hull", {})
    ei, z, depth = (hull.get("bending_stiffness_Nm2"), hull.get("section_modulus_m3"),
                    hull.get("depth_m"))
    if "bending_stiffness_Nm2" not in hull and _number(z) and _number(depth):
        hull["bending_stiffness_Nm2"] = E_STEEL * z * depth / 2.0
        defaulted["hull.bending_stiffness_Nm2"] = "derived"
    elif "section_modulus_m3" not in hull and _number(ei) and _number(depth) and depth > 0:
        hull["section_modulus_m3"] = 2.0 * ei / (E_STEEL * depth)
        defaulted["hull.section_modulus_m3"] = "derived"
    lift = out.get("lift")
    if (out.get("pipe") is None and isinstance(lift, dict | None)
            and not _given(out, "lift.catalogue_bag")):  # the first standard size tried
        out["lift"] = {**(lift or {}), "catalogue_bag": {"model": "open_parachute_50t"}}
        defaulted["lift.catalogue_bag"] = "derived"
    limits = out.get("limits")
    if (out.get("pipe") is not None and isinstance(limits, dict | None)
            and not _given(out, "limits.pitch_deg")):  # a pipe: no tilt criterion
        out["limits"] = {**(limits or {}), "pitch_deg": None}
        defaulted["limits.pitch_deg"] = "derived"
    fills = {"hull.length_between_perpendiculars_m": None, "lift.internal_bags": 0,
             "seabed.holding_shape": "uniform"}
    seabed = out.get("seabed")
    law = seabed.get("breakout_law", "timer") if isinstance(seabed, dict) else "timer"
    for key, (policy, _) in POLICY.items():
        if any(_given(out, k) for k in key.split("|")) or LAW_OF.get(key, law) != law:
            continue
        if key in fills:
            if all(isinstance(out.get(p), dict | None) for p in key.split(".")[:1]):
                _set(out, key, fills[key])
                defaulted[key] = "derived"
        elif policy == "assumed":
            defaulted[key] = "assumed"
    if defaulted:
        out["defaulted"] = dict(sorted(defaulted.items()))
    return out


def set_in(model, dotted: str) -> bool:
    """Whether the key ``dotted`` was given (set) in the validated ``model``."""
    node = model
    *path, last = dotted.split(".")
    for part in path:
        if part not in node.model_fields_set:
            return False
        node = getattr(node, part)
    return last in node.model_fields_set


def own_structure(scenario) -> bool:
    """Whether a validated scenario describes a structure of its own (module docstring)."""
    if scenario.based_on == "tanker":
        return False
    return scenario.pipe is not None or bool(set(PARTICULARS) & scenario.hull.model_fields_set)


def missing_required(scenario) -> str | None:
    """The one-line message for the first required key a structure of the user's own does
    not give (:data:`POLICY`), or None."""
    if not own_structure(scenario):
        return None
    internal = scenario.lift.internal_bags
    for key, (policy, why) in POLICY.items():
        if policy != "required" or any(set_in(scenario, k) for k in key.split("|")):
            continue
        if key in ("hull.frame_spacing_m", "hull.ballast_tank_frames") and not internal:
            continue
        names = " or ".join(key.split("|"))
        return (f"{names} is missing: a structure of your own must give it ({why}), or say "
                "based_on: tanker")
    return None


def assumed_summary(scenario) -> list[str]:
    """One line per key of ``scenario`` whose value flexlift derived or assumed (for the
    run's warning and the report's design basis): 'key = value (assumed: why)'."""
    lines = []
    data = scenario.model_dump(mode="json")
    for key, how in (scenario.defaulted or {}).items():
        why = POLICY.get(key, ("", ""))[1]
        try:
            value = _get(data, key)
        except (KeyError, TypeError):
            value = None
        lines.append(f"{key} = {_show(value)} ({how}: {why})")
    return lines


def _show(v) -> str:
    if isinstance(v, dict) and v.get("model"):  # a catalogue bag: its model's name
        return str(v["model"])
    if isinstance(v, float):
        return f"{v:.4g}"
    return "none" if v is None else str(v)


def plausibility(hull, steel_density: float) -> tuple[str | None, str | None]:
    """(refusal, warning) for a hull's mass against a solid steel block L x B x D: refused
    above it, warned above half of it and below 1 % of it (the key named)."""
    L, B, D = hull.length_m, hull.breadth_m, hull.depth_m
    block_t = L * B * D * steel_density / C.TONNE
    if hull.displacement_t is not None:
        key, mass_t = "hull.displacement_t", hull.displacement_t
    else:
        m = hull.mass_per_length_kg_m
        per = m if isinstance(m, list) else [m] * hull.elements
        key, mass_t = "hull.mass_per_length_kg_m", sum(per) * L / hull.elements / C.TONNE
    mass_t += sum(p.mass_t for p in hull.point_masses)
    if mass_t > block_t:
        return (f"{key}: {mass_t:,.6g} t is more than a solid steel block of the hull's length, "
                f"breadth and depth ({L:g} x {B:g} x {D:g} m = {block_t:,.6g} t): give the mass "
                "in tonnes (not kilograms) or check length_m, breadth_m and depth_m", None)
    if mass_t > 0.5 * block_t:
        return None, (f"{key}: {mass_t:,.6g} t is more than half a solid steel block of the "
                      f"hull's size ({block_t:,.6g} t); check the mass and the dimensions")
    if mass_t < 0.01 * block_t:
        return None, (f"{key}: {mass_t:,.6g} t is less than 1 % of a solid steel block of the "
                      f"hull's size ({block_t:,.6g} t); check the mass (tonnes) and the "
                      "dimensions")
    return None, None
