"""The controllers' fuzzy systems, defined in one readable place (docs/theory/control.md#supervisor).

- :func:`supervisor_fis` — the supervisory Mamdani controller: inputs the normalised height
  error ``e`` = (z_ref - z) / error_scale and its rate ``edot`` = (ż_ref - ż) / rate_scale, both
  in [-1, 1] (saturated); output ``u`` in [-1, 1], the change of the bag's gas volume as a
  fraction of ΔV_max. Seven Gaussian sets per variable (NB NM NS ZE PS PM PB) centred evenly
  over [-1, 1] (spacing 1/3), neighbours crossing at membership 0.5:
  σ = spacing / (2 √(2 ln 2)). Rule table :data:`SUPERVISOR_TABLE` (rows e, columns ė).
- :func:`fill_fis` — the SIFSMC's one-input map: normalised signed distance ``d`` in [-1, 1]
  to the fill fraction in [0, 1] of Q_in,max.

All quantities here are dimensionless (normalised); the scale factors live in the scenario
(``control.supervisor.error_scale_m``, ``rate_scale_m_s``, ``control.fill``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from flexlift.errors import InputError
from flexlift.fuzzy.system import FIS, MF, Rule, Variable
from flexlift.fuzzy.tables import Table1D

LABELS = ("NB", "NM", "NS", "ZE", "PS", "PM", "PB")

#: docs/theory/control.md#rule-table, verbatim: rows are the error e (PB at the top), columns the error rate ė.
SUPERVISOR_TABLE: dict[str, tuple[str, ...]] = {
    #      ė:  NB    NM    NS    ZE    PS    PM    PB
    "PB": ("ZE", "PS", "PM", "PB", "PB", "PB", "PB"),
    "PM": ("NS", "ZE", "PS", "PM", "PB", "PB", "PB"),
    "PS": ("NM", "NS", "ZE", "PS", "PM", "PB", "PB"),
    "ZE": ("NB", "NM", "NS", "ZE", "PS", "PM", "PB"),
    "NS": ("NB", "NB", "NM", "NS", "ZE", "PS", "PM"),
    "NM": ("NB", "NB", "NB", "NM", "NS", "ZE", "PS"),
    "NB": ("NB", "NB", "NB", "NB", "NM", "NS", "ZE"),
}

#: the SIFSMC map: each distance set to its fill set (odd, monotone; clipped at zero below)
FILL_MAP: dict[str, str] = {label: label for label in LABELS}

SPACING = 2.0 / (len(LABELS) - 1)  # 1/3
SIGMA = SPACING / (2.0 * math.sqrt(2.0 * math.log(2.0)))  # neighbours cross at 0.5


def gaussian_partition(name: str, labels=LABELS, lo: float = -1.0, hi: float = 1.0) -> Variable:
    """Gaussian sets centred evenly over [lo, hi], neighbours crossing at membership 0.5."""
    centres = np.linspace(lo, hi, len(labels))
    sigma = (centres[1] - centres[0]) / (2.0 * math.sqrt(2.0 * math.log(2.0)))
    return Variable(name, (lo, hi), tuple(MF(lb, "gaussmf", (sigma, c))
                                          for lb, c in zip(labels, centres)))


def triangular_partition(name: str, labels=LABELS, lo: float = -1.0, hi: float = 1.0) -> Variable:
    """Triangular sets centred evenly over [lo, hi], a partition of unity (cross at 0.5)."""
    centres = np.linspace(lo, hi, len(labels))
    h = centres[1] - centres[0]
    return Variable(name, (lo, hi), tuple(MF(lb, "trimf", (c - h, c, c + h))
                                          for lb, c in zip(labels, centres)))


def supervisor_fis(and_method: str = "min", or_method: str = "max", implication: str = "min",
                   aggregation: str = "max", defuzzification: str = "centroid",
                   resolution: int = 101) -> FIS:
    """The supervisory controller of docs/theory/control.md#supervisor (normalised, dimensionless).

    Inputs: column 0 ``e`` in [-1, 1], column 1 ``edot`` in [-1, 1]; output ``u`` in [-1, 1].
    Operators as MATLAB names them; ``resolution`` output grid points (default 101).
    """
    e, edot, u = (gaussian_partition(n) for n in ("e", "edot", "u"))
    rules = tuple(Rule((LABELS.index(row), j), LABELS.index(out))
                  for row in reversed(LABELS)
                  for j, out in enumerate(SUPERVISOR_TABLE[row]))
    return FIS("flexlift_supervisor", (e, edot), u, rules, and_method=and_method,
               or_method=or_method, implication=implication, aggregation=aggregation,
               defuzzification=defuzzification, resolution=resolution)


def supervisor_fis_from(settings) -> FIS:
    """``supervisor_fis`` with the operators of a scenario's ``control.supervisor`` section."""
    return supervisor_fis(settings.and_method, settings.or_method, settings.implication,
                          settings.aggregation, settings.defuzzification, settings.resolution)


@dataclass(frozen=True)
class FillMap:
    """The SIFSMC fill map: ``fill(d)`` -> fill fraction in [0, 1] (of Q_in,max).

    ``fis`` is the one-input Mamdani system: seven triangular sets (a partition of unity) on
    the normalised signed distance d in [-1, 1] mapped one-to-one to seven triangular sets on
    v in [-1, 1], centroid on 101 points: an odd, monotone, nearly linear map. The fill
    fraction is max(v, 0) / v(1): exactly 0 for d <= 0 (no filling when the bag has the volume
    it should; purging is the secondary controller's job), 1 at d = 1 and beyond.

    The map is monotone by construction, not by luck of rounding: the centroid is sampled once
    at ``points`` values of d over [0, 1], made non-decreasing (a running maximum removes the
    1e-16 wiggles a floating-point centroid can have) and interpolated linearly, which keeps it
    monotone. It differs from the exact centroid by less than 1e-4 of full scale (tested).
    ``fill(x)``: x a scalar, shape (n,) or (n, 1); returns a float or an array (n,).
    """

    fis: FIS
    points: int = 4001
    #: scale to 1 at d = 1 and pin 0 at d = 0 (the built-in map); False: a user's map, used
    #: as it is after checking that it is a fill fraction that does not decrease
    normalise: bool = True
    source: str = "fill map"  # names the map in errors
    table: Table1D = field(init=False, repr=False)  # fill fractions over d in [0, 1]

    def __post_init__(self):
        d = np.linspace(0.0, 1.0, self.points)
        raw = np.asarray(self.fis(d), dtype=float)
        if self.normalise:
            raw = raw / float(self.fis(1.0))
        else:
            _check_user_fill(raw, d, self.source)
        v = np.clip(np.maximum.accumulate(raw), 0.0, 1.0)
        if self.normalise:
            v[0], v[-1] = 0.0, 1.0  # d = 0 gives a centroid of +-1e-17: that is no fill
        object.__setattr__(self, "table", Table1D(v, (0.0, 1.0)))

    def __call__(self, x):
        arr = np.asarray(x, dtype=float)
        if arr.ndim == 2 and arr.shape[1] == 1:
            arr = arr[:, 0]
        if np.isnan(arr).any():
            raise InputError("fill map input", "nan", "the signed distance d must be a number")
        return self.table(arr)  # 0 below d = 0, 1 above d = 1: the loop's own lookup


def _check_user_fill(raw: np.ndarray, d: np.ndarray, source: str) -> None:
    """A user's fill map must give a fill fraction in [0, 1] that never falls as d grows."""
    if not np.all(np.isfinite(raw)) or raw.min() < -1e-9 or raw.max() > 1.0 + 1e-9:
        k = int(np.argmax(~np.isfinite(raw) | (raw < -1e-9) | (raw > 1 + 1e-9)))
        raise InputError(source, f"output {raw[k]:.4g} at d = {d[k]:.3f}",
                         "a fill map's output is a fill fraction within [0, 1]")
    drop = np.diff(raw)
    if drop.min() < -1e-6:
        k = int(np.argmin(drop))
        raise InputError(source, f"falls from {raw[k]:.4g} to {raw[k + 1]:.4g} at d = {d[k]:.3f}",
                         "a fill map must not decrease as the deficit d grows over [0, 1]")


def fill_fis(resolution: int = 101) -> FillMap:
    """The SIFSMC's one-input map (docs/theory/control.md#sifsmc): normalised signed distance -> fill fraction."""
    d, v = triangular_partition("d"), triangular_partition("v")
    rules = tuple(Rule((LABELS.index(a),), LABELS.index(b)) for a, b in FILL_MAP.items())
    return FillMap(FIS("flexlift_fill", (d,), v, rules, resolution=resolution))


def rule_table_rows() -> list[list[str]]:
    """The supervisory rule table as rows [e label, out for ė = NB..PB] (for reports)."""
    return [[row, *SUPERVISOR_TABLE[row]] for row in SUPERVISOR_TABLE]
