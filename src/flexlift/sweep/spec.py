"""The SPEC file of a sweep: a base scenario, fixed overrides, and a grid or a Monte Carlo.

::

    base: tanker                 # a built-in name, or a path (relative to this file)
    control: [coordinated]       # the control modes run per case (default: the base's mode)
    keep: summary                # or histories (every case's full time histories as netCDF)
    worst: 10                    # how many worst cases the report lists (default 10)
    set:                         # fixed overrides for every case
      simulation.duration_s: 6000
    monte_carlo:
      samples: 1000
      seed: 1
      method: lhs                # Latin hypercube (default) or random
      vary:
        lift.breakout_factor:   {dist: uniform, low: 1.2, high: 1.5}
        seabed.breakout_time_s: {dist: lognormal, median: 400, sigma: 0.3}

or, in place of ``monte_carlo``, a grid whose cases are the product of its lists (the last key
varies fastest); a list may be written ``{low: 200, high: 800, num: 4}`` (evenly spaced, or
``scale: log`` for a geometric series)::

    grid:
      seabed.breakout_time_s: [200, 400, 800]
      control.breakout_pull_t: {low: 100, high: 200, num: 3}

Every key is checked against the scenario's schema, every grid value and every distribution's
ends against the base scenario, and every controller .fis file the SPEC names (under set:, in
a grid, as a choice, or the base's own) is read and checked for its controller, before
anything runs: bad input is one line
(:class:`~flexlift.errors.InputError`). :func:`load_spec` reads a file; :func:`parse_spec`
takes the mapping.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import typing
from dataclasses import dataclass
from pathlib import Path

from flexlift import __version__
from flexlift.errors import InputError, brief, clean
from flexlift.fuzzy.fis import load_controller_fis
from flexlift.loads.scenario import load_scenario
from flexlift.plumbing import reading
from flexlift.scenario import ControlMode, Scenario, builtin_names
from flexlift.scenario.file import dump_yaml, load_yaml
from flexlift.sweep.distributions import Distribution, parse_distribution
from flexlift.sweep.keys import check_key

MODES = typing.get_args(ControlMode)
TOP_KEYS = ("base", "control", "keep", "worst", "set", "grid", "monte_carlo", "study")
MC_KEYS = ("samples", "seed", "method", "vary", "until_halfwidth", "block")
#: sampling methods of a Monte Carlo: iid designs give probabilities, sobol gives indices
METHODS = ("lhs", "random", "sobol")
#: cases per block of a sweep run until a half-width (an LHS block is its own hypercube)
BLOCK = 100
#: more cases than this need ``--yes`` (about 2 hours of tanker ascents on 2 cores)
LARGE = 100_000
#: never more cases than this in one sweep (split it)
MAX_CASES = 1_000_000


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep.

    source : the SPEC as named in messages
    base : the base scenario with ``set`` applied (every case starts from it)
    base_ref : the base as written in the SPEC (a name or a path)
    controls : the control modes run per case
    keep : ``summary`` or ``histories``
    fixed : the ``set`` overrides
    method : ``grid``, ``lhs`` or ``random``
    grid : key -> tuple of values (a grid), else empty
    distributions : key -> :class:`Distribution` (a Monte Carlo), else empty
    samples, seed : of a Monte Carlo (None for a grid); of ``sobol``: the base samples N
        (the cases are N x (groups + 2), :mod:`flexlift.sweep.sobol`); with ``halfwidth``:
        the most cases
    worst : how many worst cases the report lists
    study : the :class:`~flexlift.sweep.studies.StudyPlan` of a ready study (or None)
    halfwidth : stop once every probability's 95 % Wilson half-width is at most this (or None)
    block : cases per block when run until a half-width (an LHS block is its own hypercube)
    """

    source: str
    base: Scenario
    base_ref: str
    controls: tuple[str, ...]
    keep: str
    fixed: dict
    method: str
    grid: dict
    distributions: dict
    samples: int | None
    seed: int | None
    worst: int
    study: object = None
    halfwidth: float | None = None
    block: int | None = None

    @property
    def keys(self) -> tuple[str, ...]:
        """The varied keys, in the SPEC's order."""
        return tuple(self.grid or self.distributions)

    @property
    def n_cases(self) -> int:
        if self.method == "grid":
            return math.prod(len(v) for v in self.grid.values())
        if self.method == "sobol":
            return int(self.samples) * (len(self.groups) + 2)
        return int(self.samples)

    @property
    def groups(self) -> dict[str, list[str]]:
        """The Sobol groups: {group: its keys} (every bag's capacity factor is one group)."""
        from flexlift.sweep.studies import group_of

        out: dict[str, list[str]] = {}
        for k in self.distributions:
            out.setdefault(group_of(k), []).append(k)
        return out

    def canonical(self) -> dict:
        """What defines the cases and their results: flexlift's version, the base scenario's
        checksum (``set`` applied), the control modes, what is kept and the variations (the
        checksum is of this; ``worst`` only shapes the report)."""
        return {"flexlift": __version__, "base": self.base.checksum(),
                "controls": list(self.controls), "keep": self.keep,
                "method": self.method, "samples": self.samples, "seed": self.seed,
                "grid": {k: list(v) for k, v in self.grid.items()},
                "vary": {k: [d.kind, [list(p) for p in d.params]]
                         for k, d in self.distributions.items()},
                **({"study": self.study.name} if self.study is not None else {}),
                **({"lhs_block": self.block} if self.block and self.method == "lhs" else {})}

    def checksum(self) -> str:
        """SHA-256 of :meth:`canonical`: two sweeps with the same checksum run the same cases."""
        text = json.dumps(self.canonical(), sort_keys=True, default=repr)
        return hashlib.sha256(text.encode()).hexdigest()

    def to_yaml(self, base_file: str = "base.yaml") -> str:
        """The SPEC as run, its base the file ``base_file`` (the base with ``set`` applied),
        so that ``flexlift sweep OUT/spec.yaml --out OUT`` resumes the same sweep."""
        data = {"base": base_file, "control": list(self.controls), "keep": self.keep,
                "worst": self.worst}
        if self.method == "grid":
            data["grid"] = {k: list(v) for k, v in self.grid.items()}
        else:
            data["monte_carlo"] = {"samples": self.samples, "seed": self.seed,
                                   "method": self.method,
                                   "vary": {k: {"dist": d.kind, **dict(d.params)}
                                            for k, d in self.distributions.items()}}
            if self.halfwidth is not None:
                data["monte_carlo"].update(until_halfwidth=self.halfwidth, block=self.block)
            if self.study is not None:  # what set: fixed stays out of the study's laws
                data["study"] = self.study.name
                if self.fixed:
                    data["set"] = dict(self.fixed)
        return dump_yaml(data)


def load_spec(path: str | os.PathLike, yes: bool = False, overrides: dict | None = None
              ) -> SweepSpec:
    """Read and validate the SPEC file ``path`` (keys: ``docs/reference/sweep.md``).

    Parameters
    ----------
    path : str or path-like
        The SPEC file (YAML); a relative ``base`` path in it is relative to its folder.
    yes : bool, optional
        Allow more than :data:`LARGE` cases (100,000; never more than :data:`MAX_CASES`).
    overrides : dict, optional
        ``monte_carlo`` entries that replace the SPEC's (the command line's ``--samples``,
        ``--method``, ``--until-halfwidth``); refused for a grid.

    Returns
    -------
    SweepSpec
        The validated sweep: its base scenario with ``set`` applied, the control modes, and
        the grid or the distributions.

    Raises
    ------
    InputError
        One line naming the key, the value and what is allowed.

    Examples
    --------
    >>> import pathlib, tempfile, yaml
    >>> from flexlift.sweep import load_spec
    >>> vary = {"hydro.drag_coefficient": {"dist": "normal", "mean": 1.2, "std": 0.1}}
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = pathlib.Path(folder, "sweep.yaml")
    ...     _ = path.write_text(yaml.safe_dump({"base": "tanker", "monte_carlo": {
    ...         "samples": 200, "seed": 1, "vary": vary}}))
    ...     spec = load_spec(path)
    >>> spec.n_cases, spec.method, spec.keys
    (200, 'lhs', ('hydro.drag_coefficient',))
    """
    source = clean(os.fspath(path), 120)
    data = load_yaml(reading.read_text(path, source, reading.SPEC), source)
    if overrides and isinstance(data, dict):
        if "grid" in data:
            which = ", ".join(f"--{k.replace('_', '-')}" for k in overrides)
            raise InputError.from_line(
                f"{source}: {which} asked of a grid (its cases are its lists' product); "
                + ("Sobol indices need " if overrides.get("method") == "sobol" else "give ")
                + "monte_carlo: (samples, seed, method, vary) instead")
        mc = data.get("monte_carlo")
        data = {**data, "monte_carlo": {**(mc if isinstance(mc, dict) else {}), **overrides}}
    return parse_spec(data, source, Path(path).parent, yes)


def parse_spec(data, source: str = "spec", folder: Path | None = None,
               yes: bool = False) -> SweepSpec:
    """Validate the mapping ``data`` of a SPEC; relative base paths are in ``folder``."""
    if not isinstance(data, dict):
        raise InputError(source, brief(data, 40), "a SPEC is a mapping with base:, set:, and "
                         "grid: or monte_carlo:")
    _only(data, TOP_KEYS, source)
    base_ref = data.get("base", "tanker")
    base = _base(base_ref, source, folder)
    fixed = _mapping(data.get("set", {}), f"{source}: set")
    fixed = {k: _path(k, v, folder) for k, v in fixed.items()}
    for k in fixed:
        check_key(k, f"{source}: set")
    if fixed:
        base = _changed(base, fixed, f"{source}: set")
    checked: set = set()  # (role, path) of the .fis files read so far
    _check_files(base, f"{source}: set" if fixed else f"{source}: base", checked)
    controls = _controls(data.get("control", base.control.mode), source)
    keep = data.get("keep", "summary")
    if keep not in ("summary", "histories"):
        raise InputError(f"{source}: keep", brief(keep, 40), "use summary (headline numbers and "
                         "criteria per case) or histories (also every case's time histories)")
    worst = data.get("worst", 10)
    if isinstance(worst, bool) or not isinstance(worst, int) or not 0 <= worst <= 1000:
        raise InputError(f"{source}: worst", brief(worst, 40), "a whole number 0..1000")
    if "study" in data and "grid" in data:
        raise InputError.from_line(f"{source}: a study is a Monte Carlo; give monte_carlo: "
                                   "(samples, seed, method) with study:, not grid:")
    if "study" in data and "monte_carlo" not in data:
        data = {**data, "monte_carlo": {}}
    if ("grid" in data) == ("monte_carlo" in data):
        raise InputError.from_line(f"{source}: give either grid: (values per key) or "
                                   "monte_carlo: (samples, seed, vary), not "
                                   f"{'both' if 'grid' in data else 'neither'}")
    base_ref = base_ref.name if isinstance(base_ref, Scenario) else base_ref
    common = dict(source=source, base=base, base_ref=str(base_ref), controls=controls, keep=keep,
                  fixed=fixed, worst=worst)
    if "grid" in data:
        if isinstance(data["grid"], dict) and "method" in data["grid"]:
            raise InputError.from_line(f"{source}: grid.method: a grid has no sampling method; "
                                       "Sobol indices need monte_carlo: with method: sobol")
        grid = _grid(data["grid"], fixed, f"{source}: grid")
        grid = {k: tuple(_path(k, v, folder) for v in vs) for k, vs in grid.items()}
        spec = SweepSpec(method="grid", grid=grid, distributions={}, samples=None, seed=None,
                         **common)
        _check_size(spec, yes)
        for key, values in grid.items():  # each value against the base, before anything runs
            for v in values:
                where = f"{source}: grid.{key} = {brief(v, 40)}"
                _check_files(_changed(base, {key: v}, where), where, checked)
    else:
        mc = _mapping(data["monte_carlo"], f"{source}: monte_carlo")
        _only(mc, MC_KEYS, f"{source}: monte_carlo")
        study = None
        if "study" in data:
            from flexlift.sweep.studies import study_distributions

            base = _until_outcome(base, fixed, mc, f"{source}: study")

            base, study_dists, study = study_distributions(
                data["study"], base, _mapping(mc.get("vary"), f"{source}: monte_carlo.vary"),
                fixed, f"{source}: monte_carlo")
            common["base"] = base
            mc = {**mc, "vary": study_dists}
        samples, seed, method, dists = _monte_carlo(mc, base, fixed, f"{source}: monte_carlo",
                                                    folder, checked, study)
        halfwidth, block = _halfwidth(mc, method, f"{source}: monte_carlo")
        spec = SweepSpec(method=method, grid={}, distributions=dists, samples=samples, seed=seed,
                         study=study, halfwidth=halfwidth, block=block, **common)
        _check_size(spec, yes)
    return spec


# --------------------------------------------------------------------------- the parts
DURATION = "simulation.duration_s"


def _until_outcome(base: Scenario, fixed: dict, mc: dict, where: str) -> Scenario:
    """A study's base running each case until it has an outcome (``duration_s: auto``, at
    most the schema's longest run) unless the SPEC sets or varies the duration itself: the
    study draws slow breakouts (up to 2x nominal) a fixed duration would cut short."""
    vary = mc.get("vary")
    if DURATION in fixed or (isinstance(vary, dict) and DURATION in vary):
        return base
    return _changed(base, {DURATION: "auto"}, where)


def _only(data: dict, allowed, where: str) -> None:
    for k in data:
        if k not in allowed:
            raise InputError.from_line(f"{where}: unknown key {brief(k, 40)}; valid keys here are "
                                       + ", ".join(allowed))


def _mapping(value, where: str) -> dict:
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise InputError(where, brief(value, 40), "must be a mapping of dotted keys, e.g. "
                         "seabed.breakout_time_s: 400")
    return value


def _base(ref, source: str, folder: Path | None) -> Scenario:
    if isinstance(ref, Scenario):  # a caller's scenario in memory (flexlift.design)
        return ref
    if not isinstance(ref, str) or not ref:
        raise InputError(f"{source}: base", brief(ref, 40), "a built-in name "
                         f"({', '.join(builtin_names())}) or a path to a scenario YAML file")
    near = (folder / ref) if folder is not None and not Path(ref).is_absolute() else Path(ref)
    try:
        return load_scenario(near if reading.exists(near) else ref)  # a hull's default bag
    except InputError as exc:
        raise InputError.from_line(f"{source}: base: {exc}") from None


def _path(key: str, value, folder: Path | None):
    """A file a key names (``control.supervisor.fis_file``), relative to the SPEC's folder."""
    if (key.endswith("fis_file") and isinstance(value, str) and folder is not None
            and not Path(value).is_absolute()):
        return reading.absolute(folder / value)
    return value


def _changed(base: Scenario, changes: dict, where: str) -> Scenario:
    try:
        return base.with_changes(**changes)
    except InputError as exc:
        raise InputError.from_line(f"{where}: {exc}") from None


def _check_files(scenario: Scenario, where: str, checked: set) -> None:
    """Read and check every .fis file ``scenario`` names (``controller_files``) for its
    controller, before any case runs: a missing or unfit file is one line naming the key and
    the value that name it. ``checked`` holds the (role, path) pairs already read."""
    for key, path in scenario.controller_files().items():
        role = key.split(".")[1]
        if (role, path) in checked:
            continue
        resolution = scenario.control.supervisor.resolution if role == "supervisor" else 101
        try:
            load_controller_fis(path, role, resolution=resolution)
        except InputError as exc:
            raise InputError.from_line(f"{where}: {key}: {exc}") from None
        checked.add((role, path))


def _controls(value, source: str) -> tuple[str, ...]:
    modes = [value] if isinstance(value, str) else value
    if not isinstance(modes, list) or not modes or len(set(map(str, modes))) != len(modes):
        raise InputError(f"{source}: control", brief(value, 60), "one control mode or a list of "
                         f"different ones from {', '.join(MODES)}")
    for m in modes:
        if m not in MODES:
            raise InputError(f"{source}: control", brief(m, 40), f"use {', '.join(MODES)}")
    return tuple(modes)


def _varied(key, fixed: dict, where: str):
    k = check_key(key, where)
    if key in fixed:
        raise InputError.from_line(f"{where}: {key} is also under set:; fix it or vary it")
    if key == "name":
        raise InputError.from_line(f"{where}: name cannot vary (the cases are named "
                                   "<base name>-case_NNNN); set it under set: instead")
    return k


def _grid(grid, fixed: dict, where: str) -> dict:
    grid = _mapping(grid, where)
    if not grid:
        raise InputError.from_line(f"{where}: give at least one key with its list of values")
    out = {}
    for key, values in grid.items():
        k = _varied(key, fixed, where)
        out[key] = tuple(_values(values, f"{where}.{key}", k.kind == "whole"))
    return out


def _values(values, where: str, whole: bool) -> list:
    if isinstance(values, dict):
        return _spaced(values, where, whole)
    if not isinstance(values, list) or not values:
        raise InputError(where, brief(values, 40), "a non-empty list of values, or "
                         "{low: A, high: B, num: N} (evenly spaced; scale: log for geometric)")
    return values


def _spaced(d: dict, where: str, whole: bool) -> list:
    import numpy as np

    _only(d, ("low", "high", "num", "scale"), where)
    lo, hi, num, scale = d.get("low"), d.get("high"), d.get("num"), d.get("scale", "linear")
    for name, v in (("low", lo), ("high", hi)):
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise InputError(f"{where}.{name}", brief(v, 40), "a finite number")
    if isinstance(num, bool) or not isinstance(num, int) or not 1 <= num <= MAX_CASES:
        raise InputError(f"{where}.num", brief(num, 40), f"a whole number 1..{MAX_CASES:,}")
    if scale not in ("linear", "log"):
        raise InputError(f"{where}.scale", brief(scale, 40), "linear or log")
    if scale == "log" and not (lo > 0 and hi > 0):
        raise InputError.from_line(f"{where}: a log scale needs low and high > 0")
    vals = np.geomspace(lo, hi, num) if scale == "log" else np.linspace(lo, hi, num)
    return [int(v) for v in np.rint(vals)] if whole else [float(v) for v in vals]


def _halfwidth(mc: dict, method: str, where: str) -> tuple[float | None, int | None]:
    """(the half-width to stop at, the block size), both None when not asked for."""
    h = mc.get("until_halfwidth")
    if h is None:
        if "block" in mc:
            raise InputError.from_line(f"{where}.block: blocks are for until_halfwidth; give it "
                                       "too or remove block")
        return None, None
    if isinstance(h, bool) or not isinstance(h, int | float) or not 0 < h < 0.5:
        raise InputError(f"{where}.until_halfwidth", brief(h, 40), "a probability's 95 % "
                         "half-width, above 0 and below 0.5 (e.g. 0.01)")
    if method == "sobol":
        raise InputError.from_line(f"{where}.until_halfwidth: the Sobol design's rows give no "
                                   "probabilities; stop at a half-width with method lhs or "
                                   "random")
    block = mc.get("block", BLOCK)
    if isinstance(block, bool) or not isinstance(block, int) or not 1 <= block <= MAX_CASES:
        raise InputError(f"{where}.block", brief(block, 40), f"a whole number 1..{MAX_CASES:,}")
    return float(h), block


def _monte_carlo(mc: dict, base: Scenario, fixed: dict, where: str, folder: Path | None = None,
                 checked: set | None = None, study=None):
    samples = mc.get("samples", 1000 if study is not None else None)
    if isinstance(samples, bool) or not isinstance(samples, int) or samples <= 0:
        raise InputError(f"{where}.samples", brief(samples, 40), "a whole number >= 1")
    seed = mc.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2**63:
        raise InputError(f"{where}.seed", brief(seed, 40), "a whole number 0..2^63-1")
    method = mc.get("method", "lhs")
    if method not in METHODS:
        raise InputError(f"{where}.method", brief(method, 40), "lhs (Latin hypercube, "
                         "scipy.stats.qmc), random (plain Monte Carlo) or sobol (Saltelli's "
                         "design for Sobol indices, SALib)")
    if method == "sobol":
        from flexlift.sweep.sobol import MIN_BASE

        if samples < MIN_BASE:
            raise InputError(f"{where}.samples (--samples)", samples, f"Sobol indices need at "
                             f"least {MIN_BASE} base samples (N x (keys + 2) cases)")
    if study is not None:  # the study's laws, already parsed and checked
        _check_study_ends(base, study, mc["vary"], where)
        return samples, seed, method, dict(mc["vary"])
    vary = _mapping(mc.get("vary"), f"{where}.vary")
    if not vary:
        raise InputError.from_line(f"{where}.vary: give at least one key with its "
                                   "distribution, e.g. seabed.breakout_time_s: {dist: uniform, "
                                   "low: 200, high: 800}")
    dists: dict[str, Distribution] = {}
    for key, d in vary.items():
        k = _varied(key, fixed, f"{where}.vary")
        if isinstance(d, dict) and isinstance(d.get("values"), list):
            d = {**d, "values": [_path(key, v, folder) for v in d["values"]]}
        dist = parse_distribution(k, d, f"{where}.vary")
        ends = dist.values if dist.kind == "choice" else dist.ppf([0.0, 1.0 - 1e-16])
        for v in ends:
            at = f"{where}.vary.{key} = {brief(v, 40)}"
            _check_files(_changed(base, {key: v}, at), at, set() if checked is None else checked)
        dists[key] = dist
    return samples, seed, method, dists


def _check_study_ends(base: Scenario, study, dists: dict, where: str) -> None:
    """Every variable of a study at its low ends, then its high ends, must make a valid
    scenario (e.g. a breakout factor within its range)."""
    from flexlift.sweep.studies import study_changes

    for end, u in (("low", 0.0), ("high", 1.0 - 1e-16)):
        values = {k: d.ppf([u])[0] for k, d in dists.items()}
        _changed(base, study_changes(study, values), f"{where}: the laws' {end} ends")


def _check_size(spec: SweepSpec, yes: bool) -> None:
    n = spec.n_cases
    what = "samples" if spec.method != "grid" else "grid cases (the product of the lists)"
    if n > MAX_CASES:
        raise InputError.from_line(f"{spec.source}: {n:,} {what}; at most {MAX_CASES:,} in one "
                                   "sweep: split it into several")
    if n > LARGE and not yes:
        raise InputError.from_line(f"{spec.source}: {n:,} {what} (hours of computing); give "
                                   f"--yes to run more than {LARGE:,}")
