"""Scenario files: the pydantic schema, YAML loading and the built-in scenarios.

A scenario is the user's whole description of a lift, in YAML. Keys carry their unit in the
name (``length_m``, ``displacement_t``, ``relief_pressure_bar``): tonnes, bar and degrees are
allowed here, at the edge, and converted to SI by the stages that read them. Every section
rejects unknown keys and lists the valid ones.

Every number has a range (the comment beside each key says why; docs/reference/scenario.md
lists them): wide enough for the structures flexlift is meant for, from small pipes (EI ~1e5 N m^2)
to the largest ships (EI ~1e14 N m^2, 20,000 elements), narrow enough that a value inside
every range cannot exhaust the memory or break the numerics; what the ranges together allow
is bounded by one cost model (:mod:`flexlift.scenario.cost`: the bags after clusters, modes x
elements, steps x bags), checked for every scenario. Numbers are strict: an integer
may be given for a real number, but never a boolean or text (``elements: true`` or
``length_m: "78"`` are errors, not 1 and 78), and never NaN or infinity.

Read with :func:`read_scenario` (a built-in name such as ``"tanker"`` or a path).
"""

from __future__ import annotations

import hashlib
import math
from importlib import resources
from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Field,
    StringConstraints,
    ValidationError,
    field_validator,
    model_validator,
)

from flexlift import constants as C
from flexlift.errors import InputError, brief, clean
from flexlift.plumbing import reading
from flexlift.scenario import catalogue, cost
from flexlift.scenario.defaults import (
    complete_own_structure,
    describes_own_structure,
    missing_required,
    plausibility,
)
from flexlift.scenario.file import decode, dump_sections, dump_yaml, load_yaml, read_bytes
from flexlift.scenario.messages import first_error, format_error
from flexlift.scenario.pipe import Pipe, derive, underive
from flexlift.scenario.sensors import Sensors
from flexlift.scenario.surfacing import Surfacing
from flexlift.scenario.types import (
    MAX_BAG_LIFT_T,
    MAX_ELEMENTS,
    MAX_ITEMS,
    MAX_LENGTH_M,
    MAX_MASS_T,
    MAX_ROWS,
    MAX_STEPS,
    MAX_TIME_S,
    Flag,
    Name,
    Real,
    Text,
    real,
    whole,
)


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


# --------------------------------------------------------------------------- environment
class Environment(_Section):
    """Site and physical constants."""

    water_depth_m: real(1, 11_000) = 350.0  # seabed depth; the deepest ocean is 10,935 m
    gravity_m_s2: real(9.0, 10.5) = C.G  # Earth's is 9.76..9.84 (and the round 10 of hand checks)
    seawater_density_kg_m3: real(990, 1250) = C.RHO_SEAWATER  # fresh water 998 .. Dead Sea 1240
    steel_density_kg_m3: real(1500, 20_000) = C.RHO_STEEL  # concrete 2400, steel 7850, lead 11340
    atmospheric_pressure_Pa: real(80_000, 110_000) = C.P_ATM  # sea-level records 87.0..108.4 kPa
    sea_temperature_K: real(270, 310) = C.T_SEA  # -3 .. 37 degC


# --------------------------------------------------------------------------- hull
class PointMass(_Section):
    """A lumped mass at a ``node`` (1-based, from the aft end) or at ``x_m`` from the aft end
    (0 .. length_m, moved to the nearest node); exactly one of the two."""

    node: whole(1, MAX_ELEMENTS + 1) | None = None
    x_m: Real | None = None  # [m] from the aft end; its range 0 .. length_m is the hull's check
    mass_t: real(0.001, MAX_MASS_T)  # 1 kg .. the heaviest structure

    def node_on(self, length_m: float, elements: int) -> int:
        """The node (1-based) the mass sits at on a hull of ``length_m`` [m] in ``elements``."""
        return self.node if self.node is not None else round(self.x_m / length_m * elements) + 1


Length = real(0.1, MAX_LENGTH_M)
MassPerLength = real(0.01, 2.0e6)  # [kg/m]: a thin cable ~0.1, the largest ships ~1.4e6
Stiffness = real(1.0e3, 1.0e15)  # EI [N m^2]: small pipes ~1e5 .. the largest ships ~1e14
SectionModulus = real(1.0e-9, 1.0e3)  # Z [m^3]: a 10 mm rod ~1e-7 .. the largest ships ~100


class Hull(_Section):
    """The structure as a free-free Euler-Bernoulli beam.

    Mass: either ``displacement_t`` (uniform along the length) or ``mass_per_length_kg_m``
    (one value, or one per element). Stiffness: ``bending_stiffness_Nm2``, one value or one
    per element.
    """

    length_m: real(1, MAX_LENGTH_M) = 78.02  # length overall = beam length L; 1 m .. a 20 km pipe
    length_between_perpendiculars_m: Length | None = 72.40
    breadth_m: real(0.01, 100) = 12.0  # a 10 mm cable .. the broadest ships (~70 m)
    depth_m: real(0.01, 100) = 5.4
    elements: whole(1, MAX_ELEMENTS) = 11
    displacement_t: real(0.001, MAX_MASS_T) | None = 3200.0  # 1 kg .. the largest ships
    # the structure's submerged weight W'/g, when known directly (weighed, or from a stability
    # booklet): replaces "the whole mass is steel"; spread like the mass (scenario/defaults.py)
    submerged_weight_t: real(0.001, MAX_MASS_T) | None = None
    mass_per_length_kg_m: MassPerLength | list[MassPerLength] | None = None
    bending_stiffness_Nm2: Stiffness | list[Stiffness] = 3.0e12
    point_masses: Annotated[list[PointMass], Field(max_length=MAX_ELEMENTS + 1)] = []
    frame_spacing_m: real(0.1, 10) = 0.57  # ships' frames are 0.5..4 m apart
    ballast_tank_frames: tuple[real(0, 100_000), real(0, 100_000)] = (27, 113)
    modal_damping: Annotated[Real, Field(ge=0, lt=1)] = 0.02
    # hull girder strength: sigma = M / Z against the allowable stress. The tanker's values are
    # assumed, not published: Z about what IACS UR S7's minimum formula gives when extended to
    # L = 78 m, B = 12 m, Cb 0.75; 175 MPa the permissible bending stress of mild steel (k = 1)
    section_modulus_m3: SectionModulus | list[SectionModulus] = 0.85
    allowable_stress_MPa: real(1, 2_000) = 175.0

    @model_validator(mode="after")
    def _check(self) -> Hull:
        if (self.displacement_t is None) == (self.mass_per_length_kg_m is None):
            raise ValueError(
                "give exactly one of displacement_t (uniform) or mass_per_length_kg_m"
            )
        for name in ("mass_per_length_kg_m", "bending_stiffness_Nm2", "section_modulus_m3"):
            v = getattr(self, name)
            if isinstance(v, list) and len(v) != self.elements:
                raise ValueError(
                    f"{name} has {len(v)} values; give one value or one per element "
                    f"({self.elements})"
                )
        for k, pm in enumerate(self.point_masses):
            if (pm.node is None) == (pm.x_m is None):
                raise ValueError(f"point_masses[{k}]: give exactly one of node (1.."
                                 f"{self.elements + 1}) or x_m (0..{self.length_m:g} m)")
            if pm.x_m is not None and not 0 <= pm.x_m <= self.length_m:
                raise ValueError(f"point_masses[{k}].x_m = {pm.x_m:g} m is off the hull; "
                                 f"allowed [0, {self.length_m:g}] m (0 .. length_m)")
            if pm.node is not None and pm.node > self.elements + 1:
                raise ValueError(
                    f"point_masses node {pm.node} does not exist; nodes are 1..{self.elements + 1}"
                )
        a, b = self.ballast_tank_frames
        if not a < b:
            raise ValueError(f"ballast_tank_frames {list(self.ballast_tank_frames)} must be increasing")
        return self


# --------------------------------------------------------------------------- lift plan
BagLift = real(0.01, MAX_BAG_LIFT_T)  # [t]: 10 kg pillow bags .. the largest built


class CatalogueBag(_Section):
    """The lift bag as sold: a catalogue ``model`` (scenario/catalogue.py; the fields given
    here override the model's) or explicit fields (default: the paper's cylinder)."""

    model: Name | None = None  # an entry of the bag catalogue (flexlift/data/bags.yaml)
    type: Literal["open_parachute", "closed_parachute", "enclosed",
                  "pressurised_cylinder"] = "pressurised_cylinder"
    diameter_m: real(0.05, 20) = 1.5
    length_m: real(0.05, 50) = 18.0  # upright bags (parachute): the height, mouth down
    lift_t: BagLift = 565.0  # rated lift
    working_pressure_bar: real(0.1, 50) | None = 2.8  # pressurised cylinders; none: not stated
    relief_bar: real(0.001, 10) | None = None  # closed and enclosed bags: over ambient
    cone_top_m: real(0.01, 50) | None = None  # an upright bag's conical top (within length_m)
    dump_valve_m3_s: real(1e-6, 100) | None = None  # the maker's dump-valve capacity
    rated_depth_m: real(0.1, 12_000) | None = None  # the maker's; none: not given
    # true gas capacity over the rated one (a published incident: 1.25); the bag-count rule
    # decides how many bags, this factor their gas capacity
    capacity_factor: Annotated[Real, Field(gt=0, le=10)] = 1.0


class Rigging(_Section):
    """Slings, shackles and lift points (docs/theory/factors.md#rigging): each sling's design
    load is its bag's full true lift (a fill valve stuck open fills it); a lift point's
    capacity is compared with its design load x the consequence factor 1.30."""

    sling_wll_t: Annotated[Real, Field(gt=0, le=MAX_BAG_LIFT_T * 10)] | None = None  # per bag
    cluster_wll_t: Annotated[Real, Field(gt=0, le=1e7)] | None = None  # per lift point's gear
    sling_length_m: real(0, 1_000) = 0.0  # from the lift point to the bag's mouth
    # each external lift point's structural capacity [t], aft to bow (one number: every point)
    lift_point_capacity_t: (Annotated[Real, Field(gt=0, le=1e7)]
                            | Annotated[list[Annotated[Real, Field(gt=0, le=1e7)]],
                                        Field(min_length=1, max_length=MAX_ITEMS)]
                            | None) = None


class BagSpec(_Section):
    """One explicitly placed bag (overrides the automatic layout when ``lift.bags`` is given).

    External (parachute) bags act at a point: ``x_m`` or ``node`` (1-based). Internal
    (cylindrical) bags act over a span: ``span_m`` = [x0, x1]. ``count`` > 1 makes a cluster:
    that many bags at the one lift point, named ``<name>_1`` .. ``<name>_<count>``.
    """

    name: Name
    kind: Literal["external", "internal"]
    count: whole(1, MAX_ITEMS) = 1  # a cluster: this many identical bags at one lift point
    x_m: real(0, MAX_LENGTH_M) | None = None
    node: whole(1, MAX_ELEMENTS + 1) | None = None
    span_m: tuple[real(0, MAX_LENGTH_M), real(0, MAX_LENGTH_M)] | None = None
    lift_t: BagLift | None = None  # default: the plan's modelled lift per bag
    # this bag's true gas capacity over its rated one (each bag of a cluster); default: the
    # catalogue bag's capacity_factor (a sweep study draws one per bag)
    capacity_factor: Annotated[Real, Field(gt=0, le=10)] | None = None

    @model_validator(mode="after")
    def _check(self) -> BagSpec:
        if self.kind == "external":
            if (self.x_m is None) == (self.node is None):
                raise ValueError(f"bag {self.name}: an external bag needs exactly one of x_m or node")
            if self.span_m is not None:
                raise ValueError(f"bag {self.name}: span_m is for internal bags; use x_m or node")
        else:
            if self.span_m is None:
                raise ValueError(f"bag {self.name}: an internal bag needs span_m [x0, x1]")
            if not self.span_m[0] < self.span_m[1]:
                raise ValueError(f"bag {self.name}: span_m {list(self.span_m)} must be increasing")
        return self


class Lift(_Section):
    """How much lift, how many bags, where."""

    breakout_factor: real(1, 5) = 1.3  # required lift / wet weight; 1.3 typical, stiff clay ~2
    catalogue_bag: CatalogueBag = CatalogueBag()
    catalogue_file: Annotated[Text, Field(max_length=4096)] | None = None  # extends the catalogue
    rigging: Rigging = Rigging()
    weight_contingency: real(1, 2) | None = None  # the user's factor on the weight; none: none
    internal_bags: whole(0, MAX_ITEMS) = 3
    # balanced: lift centroid on the centre of gravity, small static bending moment (a user's
    # hull); mode_nodes: the paper's rule, external bags at the nodes of a flexible mode
    layout: Literal["balanced", "mode_nodes"] = "balanced"
    layout_flexible_mode: whole(1, 100) = 3  # mode_nodes: the flexible mode whose nodes carry the bags
    bag_lift_t: BagLift | None = None  # modelled lift per bag; default from the bag-count rule
    bags: Annotated[list[BagSpec], Field(max_length=MAX_ITEMS)] | None = None  # explicit layout

    @model_validator(mode="before")
    @classmethod
    def _model(cls, data):
        """A catalogue model's fields under the explicit ones (scenario/catalogue.py)."""
        if not isinstance(data, dict):
            return data
        bag, file = data.get("catalogue_bag"), data.get("catalogue_file")
        if (not isinstance(bag, dict) or not isinstance(bag.get("model"), str)
                or not isinstance(file, str | None)):
            return data  # no model (or a wrong type): the schema reports it
        entry = catalogue.resolve(bag["model"], file)
        merged = {k: v for k, v in entry.items() if k in CatalogueBag.model_fields}
        merged.update(bag)
        return {**data, "catalogue_bag": merged}

    @field_validator("bags")
    @classmethod
    def _unique(cls, v):
        if v is not None:
            names = [b.name for b in v]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"bag names must be unique; repeated: {brief(dup)}")
            if not v:
                raise ValueError("bags, when given, must list at least one bag")
        return v


# --------------------------------------------------------------------------- gas
class Gas(_Section):
    """Lift-bag gas and its valves (docs/theory/gas.md)."""

    relief_pressure_bar: real(0.001, 10) = 0.1  # internal bags' over-pressure relief setting
    fill_rate_max_m3_s: real(1e-4, 100) = 0.5  # at the bag's local pressure
    purge_rate_max_m3_s: real(1e-4, 100) = 2.0  # at local pressure, valve fully open, bag full
    # a compressor's free-air delivery shared by every bag it feeds [m^3/min of free air]: at
    # the bag it gives FAD p_atm / p, split over the bags filling; none: each bag fills at
    # fill_rate_max_m3_s at its own depth (the paper's assumption)
    supply_free_air_m3_min: real(0.01, 100_000) | None = None


# --------------------------------------------------------------------------- seabed
class Seabed(_Section):
    """Seabed contact and suction breakout (docs/theory/seabed.md). H_0 = (breakout_factor - 1) W'."""

    holding_shape: Literal["linear", "uniform"] = "linear"
    stern_ratio: real(0, 2) = 0.5  # holding force per length at the stern / mean (linear shape)
    bow_ratio: real(0, 2) = 1.5  # at the bow / mean (linear shape); the two sum to 2
    breakout_time_s: real(0.01, MAX_TIME_S) = 400.0  # T_b: a full pull breaks out in this time
    release_time_s: real(0.001, MAX_TIME_S) = 30.0  # tau_r: suction release after separation
    contact_stiffness_N_m2: real(1.0e3, 1.0e10) = 5.0e6  # penalty spring per unit length [N/m per m]
    contact_damping_Ns_m2: real(0, 1.0e9) = 2.0e6  # penalty damper per unit length [N s/m per m]
    # the held law (docs/theory/breakout-soil.md): timer (T_b, H0 from lift.breakout_factor) or
    # soil (H0 from the soil's strength and embedment, relief by consolidation under the pull)
    breakout_law: Literal["timer", "soil"] = "timer"
    shear_strength_kPa: real(0.01, 1000) = 3.0  # soil law: undrained shear strength s_u at the base
    embedment_m: real(0, 100) = 1.0  # soil law: depth of the hull's bottom below the mudline
    drainage_length_m: real(0.01, 1000) = 1.0  # soil law: d, the pore water's path to the base
    # soil law: c_v, an effective coefficient (calibrated, docs/theory/breakout-soil.md#calibration)
    consolidation_coefficient_m2_s: real(1e-12, 100) = 5.0e-5

    @model_validator(mode="after")
    def _check(self) -> Seabed:
        if self.holding_shape == "linear" and not math.isclose(
            self.stern_ratio + self.bow_ratio, 2.0, rel_tol=1e-9
        ):
            raise ValueError(
                f"stern_ratio + bow_ratio = {self.stern_ratio + self.bow_ratio}; "
                "must be 2 so that the mean is the total holding force"
            )
        return self


# --------------------------------------------------------------------------- hydro
class Hydro(_Section):
    """Drag and added mass (docs/theory/hydrodynamics.md)."""

    drag_coefficient: real(0, 10) = 1.2  # hull strip theory, on the breadth (bluff bodies ~1-2)
    bag_drag_coefficient: real(0, 10) = 1.0  # on the bag's frontal area
    added_mass_coefficient: real(0, 10) = 1.0  # a33 = C_a rho pi B^2 / 4 per length
    entrained_water_t: real(0, MAX_MASS_T) = 0.0  # water in flooded compartments moving with the hull


# --------------------------------------------------------------------------- control
def _fis_file(value: str) -> str:
    if any(ord(ch) < 32 or ord(ch) == 127 for ch in value):
        raise ValueError("a path without control characters")
    if not value.lower().endswith(".fis"):
        raise ValueError(f"{value!r} is not a .fis file; give the path of a MATLAB .fis file")
    return value


#: the path of a user's MATLAB .fis file (checked when it is read: it must exist and fit)
FisFile = Annotated[str, StringConstraints(min_length=5, max_length=4096),
                    AfterValidator(_fis_file)]


class Supervisor(_Section):
    """The supervisory Mamdani controller (docs/theory/control.md#supervisor)."""

    error_scale_m: real(0.01, 10_000) = 5.0
    rate_scale_m_s: real(0.001, 100) = 0.1
    volume_authority: real(0, 1) = 0.15  # Delta V_max / bag capacity
    and_method: Literal["min", "prod"] = "min"
    or_method: Literal["max", "probor"] = "max"
    implication: Literal["min", "prod"] = "min"
    aggregation: Literal["max", "sum", "probor"] = "max"
    defuzzification: Literal["centroid", "bisector", "mom", "som", "lom"] = "centroid"
    resolution: whole(11, 10_001) = 101  # points of the output universe (tables are built on it)
    # a MATLAB .fis file in place of the built-in rule base (null: built in); a relative path is
    # relative to the scenario file's folder. Two inputs (e, edot: by name, else in order), one
    # output u within [-1, 1]; evaluated at the normalised e, edot in [-1, 1]
    fis_file: FisFile | None = None


class FillControl(_Section):
    """SIFSMC fill controller on the volume deficit."""

    slope_1_s: real(1e-4, 1_000) = 0.2  # lambda in s = de/dt + lambda e [1/s]
    distance_scale_m3_s: real(1e-4, 1_000) = 0.5  # signed distance giving a full command
    # a MATLAB .fis file for the fill map (null: built in): one input d (the normalised signed
    # distance, evaluated over [0, 1]), one output: the fill fraction, non-decreasing in [0, 1]
    fis_file: FisFile | None = None


class PurgeControl(_Section):
    """PID purge controller on the volume excess; output valve opening in [0, 1]."""

    kp_1_m3: real(0, 1.0e6) = 0.5
    ki_1_m3s: real(0, 1.0e6) = 0.01
    kd_s_m3: real(0, 1.0e6) = 0.0


class Coordination(_Section):
    """Master controller for the ``coordinated`` mode."""

    pitch_gain_m3_rad: real(0, 1.0e8) = 200.0
    pitch_rate_gain_m3s_rad: real(0, 1.0e8) = 2000.0


class Sequence(_Section):
    """A staged lift (docs/theory/statics.md#staged): every bag pulls until the suction lets go; then the external
    bags begin their ascent in groups, one group every ``delay_s`` (the first at once), each
    from where it is; until its start a bag is passive and only holds its share of the weight
    (its neutral volume), so the structure peels off the seabed from one end. Either
    ``groups`` (every external bag named once, in order) or the bags in order of position
    from ``from_end``, ``group_size`` at a time."""

    groups: Annotated[list[Annotated[list[Name], Field(min_length=1, max_length=MAX_ITEMS)]],
                      Field(min_length=1, max_length=MAX_ITEMS)] | None = None
    from_end: Literal["start", "end"] = "start"  # start: x = 0 first (a pipe's KP 0, a ship's stern)
    group_size: whole(1, MAX_ITEMS) = 1
    delay_s: real(0, MAX_TIME_S) = 60.0  # between the ascents of consecutive groups


ControlMode = Literal["decentralized", "coordinated", "paper", "open-loop"]


class Control(_Section):
    """Ascent plan and the controllers (docs/theory/control.md)."""

    mode: ControlMode = "decentralized"
    sample_rate_Hz: real(0.01, 1_000) = 10.0
    target_height_m: real(0.01, 11_000) = 300.0  # above the seabed, below the surface
    ascent_speed_m_s: real(0.001, 5) = 0.2  # planned; ascents are kept well below 1 m/s
    ascent_acceleration_m_s2: real(1e-5, 1) = 0.002
    # extra buoyancy held until the hull lifts off; default (null) 18 % of the suction H_0,
    # the tanker's 150 t of 835 t: it breaks out in T_b (1/0.18 - 1) = 4.6 T_b plus the fill
    breakout_pull_t: real(0, MAX_MASS_T) | None = None
    # the pull split over the bags so its resultant sits on the suction's centroid (a plan made
    # before the lift, no communication): the hull separates level; false: equal shares
    shape_breakout_pull: Flag = True
    purge_margin: real(0.05, 1) = 0.7  # eta: the planned speed keeps the purge this far below capacity
    volume_deadband_m3: real(0, 10_000) = 0.2  # |V_d - V| below this: neither fill nor purge
    height_integral_gain_m2_s: real(0, 100) = 0.05  # neutral volume adapted per m of error [m^3/(m s)]
    measurement_filter_s: real(0, 1_000) = 0.0  # low-pass time constant of measured height, speed
    supervisor: Supervisor = Supervisor()
    fill: FillControl = FillControl()
    purge: PurgeControl = PurgeControl()
    coordination: Coordination = Coordination()
    sequence: Sequence | None = None  # a staged lift; none: every bag starts at once
    height_noise_m: real(0, 100) = 0.0
    velocity_noise_m_s: real(0, 10) = 0.0
    volume_noise_m3: real(0, 10_000) = 0.0


class Limits(_Section):
    """Acceptance criteria (docs/theory/factors.md#criteria)."""

    ascent_velocity_m_s: real(0.001, 100) = 0.6  # the largest upward speed of any bag point
    descent_velocity_m_s: real(0.001, 100) = 0.6  # the largest downward speed once separated
    # tilt: 2 deg, GL Noble Denton 0027/ND 5.3.2 for a lifted object, by analogy (the built-in
    # tanker sets the paper's 15); null: no tilt criterion (a pipe's default: its bending
    # utilisation governs)
    pitch_deg: real(0.01, 90) | None = 2.0
    arrival_tolerance_m: real(0.001, 1_000) = 1.0
    surface_clearance_m: real(0, 1_000) = 0.0  # a bag top closer than this to the surface breaches
    slope_validity_deg: real(0.1, 45) = 10.0  # a warning beyond: the small-deflection beam's validity


# --------------------------------------------------------------------------- faults
Time = real(0, MAX_TIME_S)
Duration = real(0.001, MAX_TIME_S)  # 1 ms .. 11.6 days


class _Fault(_Section):
    bag: Name
    time_s: Time


class BagRupture(_Fault):
    kind: Literal["bag_rupture"]
    leak_time_s: Duration = 5.0  # time constant of the gas escaping


class SlingBreak(_Fault):
    kind: Literal["sling_break"]


class SupplyFailure(_Fault):
    kind: Literal["supply_failure"]


class SensorDrift(_Fault):
    kind: Literal["sensor_drift"]
    rate_m_s: real(-10, 10) = 0.01  # height measurement drift rate


class SensorStuck(_Fault):
    kind: Literal["sensor_stuck"]


class SensorDropout(_Fault):
    kind: Literal["sensor_dropout"]
    duration_s: Duration = 60.0


class DumpValveStuckClosed(_Fault):
    kind: Literal["dump_valve_stuck_closed"]


class FillValveStuckOpen(_Fault):
    kind: Literal["fill_valve_stuck_open"]


class FillValveStuckClosed(_Fault):
    kind: Literal["fill_valve_stuck_closed"]


Fault = Annotated[
    BagRupture | SlingBreak | SupplyFailure | SensorDrift | SensorStuck | SensorDropout
    | DumpValveStuckClosed | FillValveStuckOpen | FillValveStuckClosed,
    Field(discriminator="kind"),
]


class Disturbance(_Section):
    """Optional environmental disturbance for robustness runs."""

    current_m_s: real(-5, 5) = 0.0  # uniform vertical current, positive up (real ones < 0.1)
    force_noise_N_m: real(0, 1.0e6) = 0.0  # std of a random vertical line load, per unit length
    noise_time_s: Duration = 10.0  # correlation time of the force noise
    seed: whole(0, 2**63 - 1) = 0  # numpy's generators take non-negative seeds


# --------------------------------------------------------------------------- simulation
class Simulation(_Section):
    """The time-domain run (docs/theory/loop.md)."""

    # stops earlier once the target has been held for hold_time_s; auto: runs until then, at
    # most the longest run the limits below allow (longest_run_s)
    duration_s: Duration | Literal["auto"] = 6000.0
    hold_time_s: Time = 600.0
    time_step_s: real(1.0e-4, 10) = 0.1  # integration step (at most the control period)
    # a number, or "auto": as many as the lift points need (ascent/plant.py retained_flexible)
    retained_flexible_modes: whole(0, 1_000) | Literal["auto"] = 3
    output_interval_s: Duration = 1.0
    strength_interval_s: Duration = 10.0  # time spacing of stored shear/moment distributions

    @field_validator("retained_flexible_modes", mode="before")
    @classmethod
    def _auto_or_number(cls, v):
        if isinstance(v, str) and v != "auto":
            raise ValueError("a number is needed here, not text (write it without quotes), "
                             "or auto (one flexible mode per lift-point interval)")
        return v

    @field_validator("duration_s", mode="before")
    @classmethod
    def _duration_or_auto(cls, v):
        if isinstance(v, str) and v != "auto":
            raise ValueError("a number is needed here, not text (write it without quotes), "
                             "or auto (until the target has been held, at most the longest run)")
        return v

    @property
    def longest_run_s(self) -> float:
        """The longest run the limits allow at this time step and output interval [s]: at most
        MAX_TIME_S, MAX_STEPS steps and MAX_ROWS stored rows (``duration_s: auto`` stops
        there)."""
        return float(min(MAX_TIME_S, MAX_STEPS * self.time_step_s,
                         MAX_ROWS * max(self.output_interval_s, self.time_step_s)))

    @property
    def run_length_s(self) -> float:
        """The duration of a run [s]: ``duration_s``, or :attr:`longest_run_s` for auto."""
        return self.longest_run_s if self.duration_s == "auto" else float(self.duration_s)

    @model_validator(mode="after")
    def _check(self) -> Simulation:
        if self.duration_s == "auto":
            return self
        steps = self.duration_s / self.time_step_s
        if steps > MAX_STEPS:
            raise ValueError(
                f"duration_s / time_step_s = {steps:.3g} steps; at most {MAX_STEPS:,} (shorten "
                "the run or lengthen the step)")
        rows = self.duration_s / max(self.output_interval_s, self.time_step_s)
        if rows > MAX_ROWS:
            raise ValueError(
                f"duration_s / output_interval_s = {rows:.3g} stored rows; at most {MAX_ROWS:,} "
                "(lengthen output_interval_s)")
        return self


# --------------------------------------------------------------------------- scenario
class Scenario(_Section):
    """A whole lift: structure, site, lift plan, physics, control and simulation."""

    name: Name = "tanker"  # names the output folder
    description: Annotated[Text, Field(max_length=10_000)] = ""
    # a file that gives its own hull particulars (or a pipe) is completed by the rules of
    # scenario/defaults.py, not with the tanker's values, unless it says based_on: tanker
    based_on: Literal["tanker"] | None = None
    # the keys flexlift derived or assumed for a structure of the user's own (listed in the
    # report's design basis); written by flexlift, kept when its scenario.yaml is rerun
    defaulted: Annotated[dict[Annotated[str, StringConstraints(max_length=80)],
                              Literal["derived", "assumed"]], Field(max_length=100)] = {}
    environment: Environment = Environment()
    hull: Hull = Hull()
    pipe: Pipe | None = None  # a pipeline by its section: fills hull, lift.bags (scenario/pipe.py)
    lift: Lift = Lift()
    gas: Gas = Gas()
    seabed: Seabed = Seabed()
    hydro: Hydro = Hydro()
    control: Control = Control()
    limits: Limits = Limits()
    faults: Annotated[list[Fault], Field(max_length=MAX_ITEMS)] = []
    disturbance: Disturbance = Disturbance()
    simulation: Simulation = Simulation()
    sensors: Sensors | None = None  # the lift's sensors (scenario/sensors.py); none: none
    # the final lift out of the water with its trapped water (scenario/surfacing.py); none: none
    surfacing: Surfacing | None = None

    @model_validator(mode="before")
    @classmethod
    def _pipe(cls, data):
        own = describes_own_structure(data)
        data = derive(data)
        return complete_own_structure(data) if own else data

    @model_validator(mode="after")
    def _check(self) -> Scenario:
        env, sim = self.environment, self.simulation
        missing = missing_required(self)
        if missing:
            raise ValueError(missing)
        if self.pipe is None:
            refusal, _ = plausibility(self.hull, env.steel_density_kg_m3)
            if refusal:
                raise ValueError(refusal)
        if self.hull.submerged_weight_t is not None:
            dry = self.hull_mass_t()
            if not self.hull.submerged_weight_t < dry:
                raise ValueError(
                    f"hull.submerged_weight_t {self.hull.submerged_weight_t:g} t must be less "
                    f"than the structure's mass ({dry:,.6g} t): in water it weighs less")
        if self.control.target_height_m >= env.water_depth_m:
            raise ValueError(
                f"control.target_height_m {self.control.target_height_m} m must be below the "
                f"water depth {env.water_depth_m} m (the target is above the seabed)"
            )
        sling, deck = self.lift.rigging.sling_length_m, self.hull.depth_m
        if sling > 0 and sling + deck >= env.water_depth_m:
            raise ValueError(
                f"lift.rigging.sling_length_m {sling:g} m must be less than "
                f"{env.water_depth_m - deck:g} m (environment.water_depth_m {env.water_depth_m:g}"
                f" m less hull.depth_m {deck:g} m): longer, a bag's mouth is above the surface "
                "with the hull still on the seabed")
        if sim.time_step_s > 1.0 / self.control.sample_rate_Hz + 1e-12:
            raise ValueError(
                f"simulation.time_step_s {sim.time_step_s} s must not exceed the "
                f"control period {1.0 / self.control.sample_rate_Hz} s"
            )
        # every range above may hold and the whole still be too much work: the bags after
        # clusters, modes x elements, steps x bags (scenario/cost.py, its limits); the
        # automatic layout's bags are counted where they are sized (loads/liftplan.py)
        too_large = cost.refusal(cost.estimate(self, bags=None if self.lift.bags else 0))
        if too_large is not None:
            raise ValueError(too_large)
        return self

    # ------------------------------------------------------------------ conveniences
    def hull_mass_t(self) -> float:
        """The structure's mass with its point masses [t]."""
        h = self.hull
        if h.displacement_t is not None:
            m = h.displacement_t
        else:
            per = h.mass_per_length_kg_m
            per = per if isinstance(per, list) else [per] * h.elements
            m = sum(per) * h.length_m / h.elements / C.TONNE
        return m + sum(p.mass_t for p in h.point_masses)

    def notes(self) -> list[str]:
        """Warnings about the scenario itself: the values flexlift derived or assumed for a
        structure of the user's own, and an implausible mass."""
        from flexlift.scenario.defaults import assumed_summary

        out = []
        lines = assumed_summary(self)
        if lines:
            out.append(f"{len(lines)} value(s) not given were derived or assumed (see the "
                       "design basis): " + "; ".join(lines))
        if self.pipe is None:
            _, warning = plausibility(self.hull, self.environment.steel_density_kg_m3)
            if warning:
                out.append(warning)
        return out

    def to_yaml(self) -> str:
        """The scenario with every default filled in, as YAML (repeatable input)."""
        data = self.model_dump(mode="json")
        if data.get("sensors") is None:  # no sensors: the text of a scenario before them
            data.pop("sensors", None)
        if data.get("surfacing") is None:  # likewise no final lift
            data.pop("surfacing", None)
        return dump_yaml(data)

    def checksum(self) -> str:
        """SHA-256 of the canonical YAML: two runs with the same checksum had the same input.
        A user's .fis file counts by its contents (its SHA-256), not by where it lies, so the
        copy in an output folder has the checksum of the original."""
        data = self.model_dump(mode="json")
        if data.get("sensors") is None:  # no sensors: the checksum of a scenario before them
            data.pop("sensors", None)
        if data.get("surfacing") is None:  # likewise no final lift
            data.pop("surfacing", None)
        for key, path in self.controller_files().items():
            section, sub_, _ = key.split(".")
            data[section][sub_]["fis_file"] = "sha256:" + file_sha256(path)
        return hashlib.sha256(dump_sections(data).encode()).hexdigest()

    def controller_files(self) -> dict[str, str]:
        """The user's .fis files by key ("control.supervisor.fis_file", ...): path."""
        c = self.control
        return {f"control.{k}.fis_file": v for k, v in
                (("supervisor", c.supervisor.fis_file), ("fill", c.fill.fis_file)) if v}

    def with_changes(self, **dotted) -> Scenario:
        """A copy with dotted keys changed, validated: ``s.with_changes(**{"hull.elements": 40})``.
        A key changed here that was assumed (``defaulted``) is given from then on (its
        assumption no longer holds: the design basis calls it the user's)."""
        data = underive(self.model_dump(mode="json"))  # a pipe's derived keys derived anew
        assumed = data.get("defaulted") or {}
        for key in dotted:  # a value given here is no longer the assumed one
            if assumed.get(key) == "assumed":
                del assumed[key]
        for key, value in dotted.items():
            node = data
            *path, last = key.split(".")
            for i, p in enumerate(path):
                node = node.setdefault(p, {})  # an unknown section is reported by the schema
                if not isinstance(node, dict):
                    raise InputError(key, brief(value), f"{'.'.join(path[: i + 1])} is a value, "
                                     "not a section with keys")
            node[last] = value
        return parse_scenario(data, source=f"{self.name} (modified)")


# --------------------------------------------------------------------------- loading
def builtin_names() -> list[str]:
    """Names of the built-in scenarios (``tanker`` is the default)."""
    folder = resources.files("flexlift") / "scenarios"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".yaml"))


def parse_scenario(data, source: str = "scenario") -> Scenario:
    """Validate a mapping as a :class:`Scenario`; raise :class:`InputError` with one line."""
    source = clean(str(source), 120)
    if not isinstance(data, dict):
        raise InputError(source, brief(data, 40) if data is None else type(data).__name__,
                         "a scenario must be a mapping of keys (name: ..., hull: ..., ...)")
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        err = first_error(exc.errors(include_url=False), Scenario)
        raise InputError.from_line(format_error(err, source, Scenario)) from None


#: what an empty file gets told
EMPTY = ("the file is empty (or only comments); an empty scenario is not read as the tanker: "
         "write `name: tanker` to start from the tanker's defaults (with flexlift's balanced "
         "layout and breakout pull; the built-in `tanker` keeps the paper's)")


def file_sha256(path) -> str:
    """SHA-256 of a .fis file's bytes (hex), or of its path when it cannot be read (no such
    file, not a regular file, larger than 1 MB: reading it for use then says so). Read within
    bounds (:mod:`flexlift.plumbing.reading`): never more than 1 MB + 1 bytes."""
    try:
        return hashlib.sha256(reading.read_bytes(path, str(path), reading.FIS)).hexdigest()
    except InputError:
        return hashlib.sha256(str(path).encode()).hexdigest()


def _resolve_files(scenario: Scenario, folder: Path) -> Scenario:
    """``scenario`` with relative .fis paths made relative to ``folder`` (the scenario file's);
    a symbolic link that loops stays as written, refused with one line when read."""
    moved = {k: reading.absolute(folder / p) for k, p in scenario.controller_files().items()
             if not Path(p).is_absolute()}
    return scenario.with_changes(**moved) if moved else scenario


def read_scenario(name_or_path: str | Path | None = None) -> Scenario:
    """Read a built-in scenario by name (default ``tanker``) or a YAML file by path, as
    written: a user's hull without a bag choice keeps the first standard size tried, marked
    ``defaulted["lift.catalogue_bag"] == "derived"``. :func:`flexlift.load_scenario`, what
    every way in calls, then chooses that bag on the lift plan (a floor above this one).

    The file is read defensively (:mod:`flexlift.scenario.file`): a regular UTF-8 file of at
    most 1 MB, one YAML document, no duplicate keys, bounded nesting and aliases; an empty
    file is an error, not the tanker. Every key and its range: ``docs/reference/scenario.md``.

    Parameters
    ----------
    name_or_path : str or path-like, optional
        A built-in name (``tanker``, ``pipeline``) or the path of a YAML file; a relative
        ``.fis`` path in it is relative to the file's folder. Default ``tanker``.

    Returns
    -------
    Scenario
        The validated scenario, every default filled in (units in the key names).

    Raises
    ------
    InputError
        One line naming the key, the value and what is allowed.

    Examples
    --------
    >>> from flexlift.scenario import read_scenario
    >>> tanker = read_scenario("tanker")
    >>> tanker.hull.length_m, tanker.lift.layout
    (78.02, 'mode_nodes')
    >>> tanker.with_changes(**{"hull.elements": 40}).hull.elements
    40
    >>> read_scenario("no-such-wreck.yaml")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    flexlift.errors.InputError: ...no such file...
    """
    if name_or_path is None:
        name_or_path = "tanker"
    source = clean(str(name_or_path), 120)
    path = Path(name_or_path)
    if isinstance(name_or_path, str) and name_or_path in builtin_names() and not reading.exists(path):
        text = (resources.files("flexlift") / "scenarios" / f"{name_or_path}.yaml").read_text()
    else:
        data = read_bytes(path, source, ", ".join(builtin_names()))
        text = decode(data, source)
    data = load_yaml(text, source)
    if data is None:
        raise InputError.from_line(f"{source}: {EMPTY}")
    if not isinstance(data, dict):
        raise InputError(source, type(data).__name__, "a scenario file must hold a YAML mapping "
                         "of keys (name: ..., hull: ..., ...)")
    lift = data.get("lift")
    if (reading.exists(path) and isinstance(lift, dict)
            and isinstance(lift.get("catalogue_file"), str)
            and not Path(lift["catalogue_file"]).is_absolute()):  # relative to the file's folder
        data = {**data, "lift": {**lift, "catalogue_file": reading.absolute(
            path.parent / lift["catalogue_file"])}}
    scenario = parse_scenario(data, source=source)
    return _resolve_files(scenario, path.parent) if reading.exists(path) else scenario
