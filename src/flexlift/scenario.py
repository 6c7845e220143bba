"""Scenario files: the pydantic schema, YAML loading and the built-in scenarios.

A scenario is the user's whole description of a lift, in YAML. Keys carry their unit in the
name (``length_m``, ``displacement_t``, ``relief_pressure_bar``): tonnes, bar and degrees are
allowed here, at the edge, and converted to SI by the stages that read them. Every section
rejects unknown keys and lists the valid ones.

Load with :func:`load_scenario` (a built-in name such as ``"tanker"`` or a path).
"""

from __future__ import annotations

import hashlib
import math
from importlib import resources
from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    field_validator,
    model_validator,
)

from flexlift import constants as C
from flexlift.errors import InputError, brief, clean
from flexlift.scenario_errors import first_error, format_error
from flexlift.scenario_file import decode, dump_yaml, load_yaml, read_bytes

Pos = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNeg = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Fraction = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


# --------------------------------------------------------------------------- environment
class Environment(_Section):
    """Site and physical constants."""

    water_depth_m: Pos = 350.0  # depth of the seabed below the surface at the wreck
    gravity_m_s2: Pos = C.G
    seawater_density_kg_m3: Pos = C.RHO_SEAWATER
    steel_density_kg_m3: Pos = C.RHO_STEEL
    atmospheric_pressure_Pa: Pos = C.P_ATM
    sea_temperature_K: Pos = C.T_SEA


# --------------------------------------------------------------------------- hull
class PointMass(_Section):
    """A lumped mass at a node (1-based, from the aft end)."""

    node: Annotated[int, Field(ge=1)]
    mass_t: Pos


class Hull(_Section):
    """The structure as a free-free Euler-Bernoulli beam.

    Mass: either ``displacement_t`` (uniform along the length) or ``mass_per_length_kg_m``
    (one value, or one per element). Stiffness: ``bending_stiffness_Nm2``, one value or one
    per element.
    """

    length_m: Pos = 78.02  # length overall = beam length L
    length_between_perpendiculars_m: Pos | None = 72.40
    breadth_m: Pos = 12.0
    depth_m: Pos = 5.4
    elements: Annotated[int, Field(ge=1)] = 11
    displacement_t: Pos | None = 3200.0
    mass_per_length_kg_m: Pos | list[Pos] | None = None
    bending_stiffness_Nm2: Pos | list[Pos] = 3.0e12
    point_masses: list[PointMass] = []
    frame_spacing_m: Pos = 0.57
    ballast_tank_frames: tuple[Annotated[float, Field(ge=0)], Annotated[float, Field(ge=0)]] = (
        27,
        113,
    )
    modal_damping: Annotated[float, Field(ge=0, lt=1)] = 0.02

    @model_validator(mode="after")
    def _check(self) -> Hull:
        if (self.displacement_t is None) == (self.mass_per_length_kg_m is None):
            raise ValueError(
                "give exactly one of displacement_t (uniform) or mass_per_length_kg_m"
            )
        for name in ("mass_per_length_kg_m", "bending_stiffness_Nm2"):
            v = getattr(self, name)
            if isinstance(v, list) and len(v) != self.elements:
                raise ValueError(
                    f"{name} has {len(v)} values; give one value or one per element "
                    f"({self.elements})"
                )
        for pm in self.point_masses:
            if pm.node > self.elements + 1:
                raise ValueError(
                    f"point_masses node {pm.node} does not exist; nodes are 1..{self.elements + 1}"
                )
        a, b = self.ballast_tank_frames
        if not a < b:
            raise ValueError(f"ballast_tank_frames {list(self.ballast_tank_frames)} must be increasing")
        return self


# --------------------------------------------------------------------------- lift plan
class CatalogueBag(_Section):
    """The lift bag as sold."""

    diameter_m: Pos = 1.5
    length_m: Pos = 18.0
    lift_t: Pos = 565.0
    working_pressure_bar: Pos = 2.8


class BagSpec(_Section):
    """One explicitly placed bag (overrides the automatic layout when ``lift.bags`` is given).

    External (parachute) bags act at a point: ``x_m`` or ``node`` (1-based). Internal
    (cylindrical) bags act over a span: ``span_m`` = [x0, x1].
    """

    name: Annotated[str, Field(min_length=1)]
    kind: Literal["external", "internal"]
    x_m: NonNeg | None = None
    node: Annotated[int, Field(ge=1)] | None = None
    span_m: tuple[NonNeg, NonNeg] | None = None
    lift_t: Pos | None = None  # default: the plan's modelled lift per bag

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

    breakout_factor: Annotated[float, Field(ge=1)] = 1.3  # required lift / wet weight
    catalogue_bag: CatalogueBag = CatalogueBag()
    internal_bags: Annotated[int, Field(ge=0)] = 3
    layout_flexible_mode: Annotated[int, Field(ge=1)] = 3  # external bags at this flexible mode's nodes
    bag_lift_t: Pos | None = None  # modelled lift per bag; default from the bag-count rule
    bags: list[BagSpec] | None = None  # explicit layout instead of the automatic one

    @field_validator("bags")
    @classmethod
    def _unique(cls, v):
        if v is not None:
            names = [b.name for b in v]
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"bag names must be unique; repeated: {dup}")
            if not v:
                raise ValueError("bags, when given, must list at least one bag")
        return v


# --------------------------------------------------------------------------- gas
class Gas(_Section):
    """Lift-bag gas and its valves (SPEC §5)."""

    relief_pressure_bar: Pos = 0.1  # internal bags' over-pressure relief setting
    fill_rate_max_m3_s: Pos = 0.5  # at the bag's local pressure
    purge_rate_max_m3_s: Pos = 2.0  # at local pressure, valve fully open, bag full


# --------------------------------------------------------------------------- seabed
class Seabed(_Section):
    """Seabed contact and suction breakout (SPEC §6). H_0 = (breakout_factor - 1) W'."""

    holding_shape: Literal["linear", "uniform"] = "linear"
    stern_ratio: NonNeg = 0.5  # holding force per length at the stern / mean (linear shape)
    bow_ratio: NonNeg = 1.5  # at the bow / mean (linear shape)
    breakout_time_s: Pos = 400.0  # T_b: a full pull breaks out in this time
    release_time_s: Pos = 30.0  # tau_r: suction release after separation
    contact_stiffness_N_m2: Pos = 5.0e6  # penalty spring per unit length [N/m per m]
    contact_damping_Ns_m2: NonNeg = 2.0e6  # penalty damper per unit length [N s/m per m]

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
    """Drag and added mass (SPEC §6)."""

    drag_coefficient: NonNeg = 1.2  # hull strip theory, on the breadth
    bag_drag_coefficient: NonNeg = 1.0  # on the bag's frontal area
    added_mass_coefficient: NonNeg = 1.0  # a33 = C_a rho pi B^2 / 4 per length
    entrained_water_t: NonNeg = 0.0  # water in flooded compartments moving with the hull


# --------------------------------------------------------------------------- control
class Supervisor(_Section):
    """The supervisory Mamdani controller (SPEC §7)."""

    error_scale_m: Pos = 5.0
    rate_scale_m_s: Pos = 0.1
    volume_authority: Fraction = 0.15  # Delta V_max / bag capacity
    and_method: Literal["min", "prod"] = "min"
    or_method: Literal["max", "probor"] = "max"
    implication: Literal["min", "prod"] = "min"
    aggregation: Literal["max", "sum", "probor"] = "max"
    defuzzification: Literal["centroid", "bisector", "mom", "som", "lom"] = "centroid"
    resolution: Annotated[int, Field(ge=11)] = 101


class FillControl(_Section):
    """SIFSMC fill controller on the volume deficit."""

    slope_1_s: Pos = 0.2  # lambda in s = de/dt + lambda e [1/s]
    distance_scale_m3_s: Pos = 0.5  # signed distance that maps to a full command [m^3/s]


class PurgeControl(_Section):
    """PID purge controller on the volume excess; output valve opening in [0, 1]."""

    kp_1_m3: NonNeg = 0.5
    ki_1_m3s: NonNeg = 0.01
    kd_s_m3: NonNeg = 0.0


class Coordination(_Section):
    """Master controller for the ``coordinated`` mode."""

    pitch_gain_m3_rad: NonNeg = 200.0
    pitch_rate_gain_m3s_rad: NonNeg = 2000.0
    shape_breakout_pull: bool = True


ControlMode = Literal["decentralized", "coordinated", "paper", "open-loop"]


class Control(_Section):
    """Ascent plan and the controllers (SPEC §7)."""

    mode: ControlMode = "decentralized"
    sample_rate_Hz: Pos = 10.0
    target_height_m: Pos = 300.0  # above the seabed
    ascent_speed_m_s: Pos = 0.2
    ascent_acceleration_m_s2: Pos = 0.002
    breakout_pull_t: NonNeg = 150.0  # extra buoyancy held until the hull lifts off
    volume_deadband_m3: NonNeg = 0.2  # |V_d - V| below this: neither fill nor purge
    supervisor: Supervisor = Supervisor()
    fill: FillControl = FillControl()
    purge: PurgeControl = PurgeControl()
    coordination: Coordination = Coordination()
    height_noise_m: NonNeg = 0.0
    velocity_noise_m_s: NonNeg = 0.0
    volume_noise_m3: NonNeg = 0.0


class Limits(_Section):
    """Acceptance criteria (SPEC §1, §7)."""

    ascent_velocity_m_s: Pos = 0.6
    pitch_deg: Pos = 15.0
    arrival_tolerance_m: Pos = 1.0
    surface_clearance_m: NonNeg = 0.0  # a bag top closer than this to the surface breaches


# --------------------------------------------------------------------------- faults
class _Fault(_Section):
    bag: str
    time_s: NonNeg


class BagRupture(_Fault):
    kind: Literal["bag_rupture"]
    leak_time_s: Pos = 5.0  # time constant of the gas escaping


class SlingBreak(_Fault):
    kind: Literal["sling_break"]


class SupplyFailure(_Fault):
    kind: Literal["supply_failure"]


class SensorDrift(_Fault):
    kind: Literal["sensor_drift"]
    rate_m_s: float = 0.01  # height measurement drift rate


class SensorStuck(_Fault):
    kind: Literal["sensor_stuck"]


class SensorDropout(_Fault):
    kind: Literal["sensor_dropout"]
    duration_s: Pos = 60.0


Fault = Annotated[
    BagRupture | SlingBreak | SupplyFailure | SensorDrift | SensorStuck | SensorDropout,
    Field(discriminator="kind"),
]


class Disturbance(_Section):
    """Optional environmental disturbance for robustness runs."""

    current_m_s: float = 0.0  # uniform vertical current, positive up
    force_noise_N_m: NonNeg = 0.0  # std of a random vertical line load, per unit length
    noise_time_s: Pos = 10.0  # correlation time of the force noise
    seed: int = 0


# --------------------------------------------------------------------------- simulation
class Simulation(_Section):
    """The time-domain run (SPEC §8)."""

    duration_s: Pos = 6000.0  # stops earlier once the target has been held for hold_time_s
    hold_time_s: NonNeg = 600.0
    time_step_s: Pos = 0.1  # integration step (at most the control period)
    retained_flexible_modes: Annotated[int, Field(ge=0)] = 3
    output_interval_s: Pos = 1.0
    strength_interval_s: Pos = 10.0  # time spacing of stored shear/moment distributions


# --------------------------------------------------------------------------- scenario
class Scenario(_Section):
    """A whole lift: structure, site, lift plan, physics, control and simulation."""

    name: Annotated[str, Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")] = "tanker"
    description: str = ""
    environment: Environment = Environment()
    hull: Hull = Hull()
    lift: Lift = Lift()
    gas: Gas = Gas()
    seabed: Seabed = Seabed()
    hydro: Hydro = Hydro()
    control: Control = Control()
    limits: Limits = Limits()
    faults: list[Fault] = []
    disturbance: Disturbance = Disturbance()
    simulation: Simulation = Simulation()

    @model_validator(mode="after")
    def _check(self) -> Scenario:
        if self.control.target_height_m >= self.environment.water_depth_m:
            raise ValueError(
                f"control.target_height_m {self.control.target_height_m} m must be below the "
                f"water depth {self.environment.water_depth_m} m (the target is above the seabed)"
            )
        if self.simulation.time_step_s > 1.0 / self.control.sample_rate_Hz + 1e-12:
            raise ValueError(
                f"simulation.time_step_s {self.simulation.time_step_s} s must not exceed the "
                f"control period {1.0 / self.control.sample_rate_Hz} s"
            )
        return self

    # ------------------------------------------------------------------ conveniences
    def to_yaml(self) -> str:
        """The scenario with every default filled in, as YAML (repeatable input)."""
        return dump_yaml(self.model_dump(mode="json"))

    def checksum(self) -> str:
        """SHA-256 of the canonical YAML: two runs with the same checksum had the same input."""
        return hashlib.sha256(self.to_yaml().encode()).hexdigest()

    def with_changes(self, **dotted) -> Scenario:
        """A copy with dotted keys changed, validated: ``s.with_changes(**{"hull.elements": 40})``."""
        data = self.model_dump(mode="json")
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
         "write `name: tanker` to start from the tanker's defaults")


def load_scenario(name_or_path: str | Path | None = None) -> Scenario:
    """Load a built-in scenario by name (default ``tanker``) or a YAML file by path.

    The file is read defensively (:mod:`flexlift.scenario_file`): a regular UTF-8 file of at
    most 1 MB, one YAML document, no duplicate keys, bounded nesting and aliases; an empty
    file is an error, not the tanker."""
    if name_or_path is None:
        name_or_path = "tanker"
    source = clean(str(name_or_path), 120)
    path = Path(name_or_path)
    if isinstance(name_or_path, str) and name_or_path in builtin_names() and not path.exists():
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
    return parse_scenario(data, source=source)
