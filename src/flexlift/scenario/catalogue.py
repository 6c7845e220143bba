"""The lift-bag catalogue: the bags a plan can name by ``lift.catalogue_bag.model``.

The packaged catalogue (``flexlift/data/bags.yaml``) holds generic entries built from the
stated rules of :func:`generic_entry`, for the sizes salvors use (1 .. 50 t), and the paper's
pressurised cylinder as published. No vendor's product: a user with a maker's data sheet
names a catalogue file of their own (``lift.catalogue_file``, same format), which extends the
packaged one. Every entry is checked (:func:`check_entry`): a missing or non-physical field
is one line.

The rules of a generic entry (docs/theory/factors.md#bag-catalogue):

- gas volume at full lift V = lift / (rho_sw g) = 1000 lift_t / 1025 [m^3];
- open and closed parachute bags: an upright cylinder (mouth down) of height 1.5 D;
  enclosed bags: a horizontal cylinder of length 3 D; D from V = pi D^2 L / 4, D and L
  rounded up to the centimetre (so the body holds V);
- relief: open bags spill at the mouth (none); closed parachute and enclosed bags relieve at
  0.1 bar (10 kPa) over ambient;
- dump-valve capacity: a full bag's volume in 120 s (assumed; a maker's figure replaces it);
- rated depth and working pressure: not stated for a generic bag (a maker's figure; the
  rated-depth check says "not given").
"""

from __future__ import annotations

import difflib
import math
from importlib import resources

from flexlift.errors import InputError, clean

__all__ = ["TYPES", "SIZES_T", "generic_entry", "check_entry", "builtin", "load", "resolve"]

#: the bag types and their proportion: length (height for the upright ones) / diameter
TYPES = {"open_parachute": 1.5, "closed_parachute": 1.5, "enclosed": 3.0,
         "pressurised_cylinder": None}
#: the generic sizes [t]: diver bags to the largest parachute bags in use
SIZES_T = (1, 2, 5, 10, 20, 35, 50)
RHO_RULE = 1025.0  # [kg/m^3] seawater density of the volume rule
RELIEF_CLOSED_BAR = 0.1  # closed parachute and enclosed bags relieve 10 kPa over ambient
DUMP_TIME_S = 120.0  # a generic dump valve empties a full bag in this time
FIELDS = ("type", "lift_t", "diameter_m", "length_m", "working_pressure_bar", "relief_bar",
          "dump_valve_m3_s", "rated_depth_m", "cone_top_m", "cost", "as_published", "source")
REQUIRED = ("type", "lift_t", "diameter_m", "length_m")
UPRIGHT = ("open_parachute", "closed_parachute")  # length_m is the height, mouth down


def _up(x: float, q: float = 0.01) -> float:
    return round(math.ceil(x / q - 1e-9) * q, 2)


def generic_entry(kind: str, lift_t: float) -> dict:
    """The generic catalogue entry of type ``kind`` and rated lift ``lift_t`` [t] by the rules
    of the module docstring."""
    V = lift_t * 1000.0 / RHO_RULE
    ratio = TYPES[kind]
    D = _up((4.0 * V / (ratio * math.pi)) ** (1.0 / 3.0))
    return {"type": kind, "lift_t": float(lift_t), "diameter_m": D, "length_m": _up(ratio * D),
            "working_pressure_bar": None,
            "relief_bar": None if kind == "open_parachute" else RELIEF_CLOSED_BAR,
            "dump_valve_m3_s": float(f"{V / DUMP_TIME_S:.3g}"), "rated_depth_m": None,
            "source": "generic rule (flexlift/data/bags.yaml)"}


def body_volume(entry: dict) -> float:
    """The volume the bag's body holds [m^3]: a cylinder of its diameter and length (less two
    thirds of the cylinder around its conical top, ``cone_top_m``, when it has one)."""
    cone = entry.get("cone_top_m") or 0.0
    return math.pi * entry["diameter_m"] ** 2 * (entry["length_m"] - 2.0 * cone / 3.0) / 4.0


def rated_volume(entry: dict) -> float:
    """The gas volume of its rated lift [m^3] (the rule's density)."""
    return entry["lift_t"] * 1000.0 / RHO_RULE


def height(entry: dict) -> float:
    """The bag's height above its lift point [m]: its length when upright (parachute bags,
    mouth down), its diameter when lying (enclosed bags and cylinders)."""
    return entry["length_m"] if entry["type"] in UPRIGHT else entry["diameter_m"]


def _num(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def check_entry(name: str, entry, source: str, packaged: bool = False) -> dict:
    """``entry`` checked: the required fields, positive numbers, a known type, and a body
    that holds the rated volume (unless ``as_published``: the paper's cylinder is kept as
    published and says so). ``as_published`` belongs to the packaged catalogue only
    (``packaged``) and is strictly ``true``/``false`` there; a user's entry giving it is
    refused. An InputError of one line otherwise."""
    where = f"{source}: bag {clean(str(name), 60)}"
    if not isinstance(entry, dict):
        raise InputError.from_line(f"{where}: an entry must be a mapping of fields "
                                   f"({', '.join(REQUIRED)}, ...)")
    fields = FIELDS if packaged else tuple(f for f in FIELDS if f != "as_published")
    if "as_published" in entry and not packaged:
        raise InputError.from_line(
            f"{where}: as_published = {clean(str(entry['as_published']), 40)} is for the "
            "packaged catalogue only; remove it (a body must hold its rated volume)")
    if packaged and not isinstance(entry.get("as_published", False), bool):
        raise InputError.from_line(f"{where}: as_published = "
                                   f"{clean(str(entry['as_published']), 40)} must be true or "
                                   "false")
    unknown = sorted(set(entry) - set(fields))
    if unknown:
        raise InputError.from_line(f"{where}: unknown field {clean(str(unknown[0]), 40)}; the "
                                   f"fields are {', '.join(fields)}")
    for f in REQUIRED:
        if entry.get(f) is None:
            raise InputError.from_line(f"{where}: {f} is missing (required: "
                                       f"{', '.join(REQUIRED)})")
    if entry["type"] not in TYPES:
        raise InputError.from_line(f"{where}: type {clean(str(entry['type']), 40)} is not one "
                                   f"of {', '.join(TYPES)}")
    for f in ("lift_t", "diameter_m", "length_m", "working_pressure_bar", "relief_bar",
              "dump_valve_m3_s", "rated_depth_m", "cone_top_m", "cost"):
        v = entry.get(f)
        if v is not None and not (_num(v) and v > 0):
            raise InputError.from_line(f"{where}: {f} = {clean(str(v), 40)} must be a positive "
                                       "number")
    cone = entry.get("cone_top_m")
    if cone is not None and (entry["type"] not in UPRIGHT or cone >= entry["length_m"]):
        raise InputError.from_line(
            f"{where}: cone_top_m = {cone:g} m is the conical top of an upright (parachute) "
            f"bag, less than its length_m ({entry['length_m']:g} m)")
    if entry.get("as_published") is not True and body_volume(entry) < rated_volume(entry) * (1 - 1e-3):
        raise InputError.from_line(
            f"{where}: a body of {entry['diameter_m']:g} m x {entry['length_m']:g} m holds "
            f"{body_volume(entry):.3g} m3, less than the {rated_volume(entry):.3g} m3 of gas its "
            f"{entry['lift_t']:g} t lift needs; check the dimensions or the lift")
    return dict(entry)


def _parse(text: str, source: str, packaged: bool = False) -> dict:
    from flexlift.scenario.file import load_yaml

    data = load_yaml(text, source)
    bags = data.get("bags") if isinstance(data, dict) else None
    if not isinstance(bags, dict) or not bags:
        raise InputError.from_line(f"{source}: a bag catalogue is a mapping `bags:` of named "
                                   "entries (type, lift_t, diameter_m, length_m, ...)")
    return {str(k): check_entry(k, v, source, packaged) for k, v in bags.items()}


_BUILTIN: dict | None = None


def builtin() -> dict:
    """The packaged catalogue: name -> entry."""
    global _BUILTIN
    if _BUILTIN is None:
        text = (resources.files("flexlift") / "data" / "bags.yaml").read_text()
        _BUILTIN = _parse(text, "flexlift/data/bags.yaml", packaged=True)
    return dict(_BUILTIN)


def load(user_file: str | None = None) -> dict:
    """The packaged catalogue extended by ``user_file`` (read within the bounds of
    :mod:`flexlift.plumbing.reading`); a name of the packaged one may not be redefined."""
    cat = builtin()
    if user_file is None:
        return cat
    from flexlift.plumbing import reading

    source = clean(str(user_file), 120)
    kind = reading.SCENARIO.with_missing("give the path of a bag catalogue (a YAML file)")
    text = reading.read_text(user_file, source, kind)
    for name, entry in _parse(text, source).items():
        if name in cat:
            raise InputError.from_line(f"{source}: bag {clean(name, 60)} is a packaged "
                                       "catalogue name; give your entry another name")
        cat[name] = entry
    return cat


def resolve(model: str, user_file: str | None = None) -> dict:
    """The entry named ``model``; an unknown name is one line with the near names."""
    cat = load(user_file)
    if model in cat:
        return cat[model]
    near = difflib.get_close_matches(str(model), list(cat), n=4, cutoff=0.5)
    hint = f"near: {', '.join(near)}" if near else f"e.g. {', '.join(sorted(cat)[:4])}"
    raise InputError.from_line(
        f"lift.catalogue_bag.model: {clean(str(model), 60)} is not in the bag catalogue "
        f"({hint}; the list: flexlift/data/bags.yaml"
        + (f" and {clean(str(user_file), 80)}" if user_file else "") + ")")
