"""What a scenario costs to compute, estimated before any work: one model for the schema
check, the options and the sweeps (issue 21).

:func:`estimate` counts what the work grows with: the bags after clusters (a ``count: 1000``
entry is 1,000 bags; a pipe's lift points times their ``count``), the elements and the modes
computed on them, the time steps, the stored rows and snapshots; and turns them into an
estimated wall time on one busy core and a peak memory. :func:`check` refuses, with the
estimate in the one-line message, what is beyond the limits below. The schema calls it for
every scenario with its explicit bags (so a file, a sweep's case and an option such as
``--duration``, which is applied as its key, are held to the same limits), the lift-plan sizer
for the bags of the automatic layout (their count is known exactly only there, once the hull's
wet weight is; the sizer runs before any bag is laid out), ``flexlift modes`` for its ``--elements``
and ``--modes``, and ``flexlift sweep`` for cases x per-case cost.

===========================  ===============  =============================================
limit                        value            why
===========================  ===============  =============================================
bags after clusters          2,000            a pipeline of a few hundred lift points with
                                              clusters; 400 bags (the benchmark) run in ~1 min
``flexlift run`` (estimate)  600 s            10 minutes on a 2-core machine, both busy: a
                                              scenario beyond is refused up front
peak memory (estimate)       4 GB             a small 2-core machine's memory
a sweep (cases x cost /      600 s            beyond, ``--yes`` is needed (as for more than
workers)                                      100,000 cases)
===========================  ===============  =============================================

The model (calibrated on 2026-12-01 with small sizes on the 2-core test machine under a
load of ~10, i.e. ~5x slower than an idle core, then extrapolated; it over-estimates on an
idle machine, never the other way on the sizes measured):

- modes of N elements, k modes (D = 2N + 2 degrees of freedom): up to 4,002 DOFs,
  0.05 + 5e-8 D k^2 s, plus 3e-9 D^3 s for a dense solve (k beyond about 2 sqrt(N), the
  modes the flexibility form does not resolve) and 8e-6 k^3 s when Lanczos runs (k < D/2);
  beyond, Lanczos alone: 0.05 + 1.2e-5 N k + 4e-7 N k^2 + 8e-6 k^3 s. Measured for one
  solve: 0.34-20 s for N 200-16,000, k 24-162 (N 1,000 k 112 20 s, N 16,000 k 24 2.6 s);
  ``flexlift modes`` (two solves, the convergence study, figures) 52 s for 400 elements
  (802 modes; 55 s estimated), 68 s for 4,000 elements and 100 modes (58 s estimated);
- one time step with B bags, nr retained modes (2 rigid + flexible) and ns load strips
  (4 per element up to 50 elements, else 200): 5 + 0.015 ns nr + 0.3 B + 1.5e-3 B^2 +
  0.07 B nr microseconds (measured 6.8 us for the tanker, 128 us for 200 strips x 42 modes,
  48 / 231 / 982 us for 100 / 400 / 800 bags, 273 us for 100 bags x 22 modes);
- the plant and the plan 1 ms per bag; the reduction stage 0.05 s per bag; the stored
  rows 5 us per bag-row per control mode (files, figures);
- memory: 0.3 GB + 800 bytes per bag-row (the 181-bag tanker: 1.1 GB measured, 1.2
  estimated) + 48 bytes per node-snapshot + 32 D k bytes for the modes.

``flexlift run`` simulates two control modes (decentralized, coordinated); a step's cost is
counted for the whole ``simulation.duration_s`` (an ascent that arrives early stops early).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from flexlift.errors import InputError

#: the most bags after clusters (lift.bags entries times their count; a pipe's lift points
#: times their count; the bags the plan sizer sizes)
MAX_BAGS = 2_000
#: the longest estimated ``flexlift run`` accepted [s]
MAX_SECONDS = 600.0
#: the largest estimated peak memory accepted [bytes]
MAX_MEMORY = 4.0e9
#: control modes ``flexlift run`` simulates by default (stages.run.DEFAULT_CONTROLS)
RUN_CONTROLS = 2
#: flexible modes of ``retained_flexible_modes: auto`` (ascent.plant.AUTO_FLEXIBLE_MODES)
AUTO_MODES = (3, 60)
#: modes the plant computes at least, and beyond the retained ones
#: (ascent.plant.MODES_FOR_CORRECTION, and its 10 more for the static correction)
PLANT_MODES, CORRECTION_MODES = 24, 10
#: the modes stage's default: every mode up to this many elements, else 22
#: (structure.modes.LARGE_MODEL_ELEMENTS)
ALL_MODES_ELEMENTS, STAGE_MODES = 400, 22
#: the largest model solved densely (structure.eigen.DENSE_MAX_DOF)
DENSE_MAX_DOF = 4002
#: load strips: 4 per element up to 50 elements, else 200 (ascent.plant.strip_points)
FINE_MESH_ELEMENTS, COARSE_STRIPS = 50, 200


@dataclass(frozen=True)
class Cost:
    """The estimated size and cost of a scenario's work."""

    bags: int  #: bags after clusters
    elements: int
    modes: int  #: modes the ascent's plant computes, rigid included
    retained: int  #: flexible modes the ascent integrates
    steps: int  #: time steps of one ascent (the whole duration)
    rows: int  #: stored rows of one ascent
    ascent_s: float  #: one ascent, plant included [s]
    run_s: float  #: ``flexlift run``: the modes stage, the reduction, two ascents [s]
    memory: float  #: peak memory of one ascent [bytes]

    def text(self) -> str:
        """The estimate in words, for a message."""
        return (f"{self.bags:,} bags, {self.elements:,} elements, {self.modes:,} modes, "
                f"{self.steps:,} steps: {_time(self.run_s)} (flexlift run), "
                f"{self.memory / 1e9:.2g} GB")


def _time(s: float) -> str:
    if s < 120:
        return f"{s:.0f} s"
    if s < 7200:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:,.0f} h"


def modes_seconds(elements: int, modes: int) -> float:
    """Estimated time to compute ``modes`` modes of ``elements`` elements [s]."""
    n, k = float(elements), float(modes)
    d = 2.0 * n + 2.0
    if d <= DENSE_MAX_DOF:
        # the dense solve runs for the modes above sqrt(lambda_1 lambda_max), about mode
        # 2 sqrt(N) (structure.eigen.flexibility_and_stiffness)
        t = 0.05 + 5e-8 * d * k * k + (3e-9 * d**3 if k > 2.0 * math.sqrt(n) else 0.0)
        return t + (8e-6 * k**3 if 2 * k < d else 0.0)
    return 0.05 + 1.2e-5 * n * k + 4e-7 * n * k * k + 8e-6 * k**3


def step_seconds(bags: int, retained_total: int, strips: int) -> float:
    """Estimated time of one time step [s] (bags, modes incl. rigid, load strips)."""
    b, nr = float(bags), float(retained_total)
    return 1e-6 * (5.0 + 0.015 * strips * nr + 0.3 * b + 1.5e-3 * b * b + 0.07 * b * nr)


def stage_modes(elements: int, modes: int | None = None) -> int:
    """The modes ``flexlift modes`` computes: ``modes``, or its default."""
    if modes is not None:
        return int(modes)
    return 2 * elements + 2 if elements <= ALL_MODES_ELEMENTS else STAGE_MODES


def count_bags(scenario) -> tuple[int, int]:
    """(bags after clusters, distinct external lift points) of an explicit layout or a
    pipe's lift points; for the automatic layout, the bag-count rule on the hull's mass (the
    plan sizer counts exactly and checks again)."""
    lift = scenario.lift
    if lift.bags is not None:
        bags = sum(b.count for b in lift.bags)
        points = len({(b.x_m, b.node) for b in lift.bags if b.kind == "external"})
        return bags, points
    hull, env = scenario.hull, scenario.environment
    if hull.displacement_t is not None:
        mass_t = hull.displacement_t
    else:
        q = hull.mass_per_length_kg_m
        mean = sum(q) / len(q) if isinstance(q, list) else q
        mass_t = mean * hull.length_m / 1000.0
    mass_t += sum(p.mass_t for p in hull.point_masses)
    wet_t = mass_t * max(0.0, 1.0 - env.seawater_density_kg_m3 / env.steel_density_kg_m3)
    need_t = lift.breakout_factor * (lift.weight_contingency or 1.0) * wet_t
    n = max(1, math.ceil(need_t / lift.catalogue_bag.lift_t - 1e-9))
    return n, max(0, n - min(lift.internal_bags, n))


def estimate(scenario, bags: int | None = None, duration: float | None = None) -> Cost:
    """The estimated cost of ``scenario`` (a validated :class:`~flexlift.scenario.Scenario`).

    bags : the bags after clusters when known (the plan sizer's count); default counted here
    duration : the simulated time [s] (default ``simulation.duration_s``)
    """
    n_bags, points = count_bags(scenario)
    if bags is not None:
        n_bags, points = int(bags), min(points, int(bags)) if points else int(bags)
    sim = scenario.simulation
    n = scenario.hull.elements
    if sim.retained_flexible_modes == "auto":
        lo, hi = AUTO_MODES
        retained = min(max(points, lo), hi)
    else:
        retained = int(sim.retained_flexible_modes)
    dof = 2 * n + 2
    k = min(dof, max(PLANT_MODES, 2 + retained + CORRECTION_MODES))
    nr = min(2 + retained, k)
    strips = 4 * n if n <= FINE_MESH_ELEMENTS else COARSE_STRIPS
    if duration is not None:
        t_end = float(duration)
    elif sim.duration_s == "auto":
        t_end = min(sim.longest_run_s, expected_run_s(scenario))
    else:
        t_end = float(sim.duration_s)
    steps = math.ceil(t_end / sim.time_step_s - 1e-9)
    rows = math.floor(t_end / max(sim.output_interval_s, sim.time_step_s)) + 1
    snaps = math.floor(t_end / max(sim.strength_interval_s, sim.time_step_s)) + 1
    ascent = (modes_seconds(n, k) + 1e-3 * n_bags + steps * step_seconds(n_bags, nr, strips)
              + 5e-6 * rows * n_bags)
    run = (modes_seconds(n, stage_modes(n)) + 0.05 * n_bags + RUN_CONTROLS * ascent)
    memory = 0.3e9 + 800.0 * rows * n_bags + 48.0 * snaps * max(n + 1, strips) + 32.0 * dof * k
    return Cost(n_bags, n, k, retained, steps, rows, ascent, run, memory)


def over(cost: Cost) -> str | None:
    """What ``cost`` is over, or None when it is within every limit."""
    if cost.bags > MAX_BAGS:
        return f"at most {MAX_BAGS:,} bags after clusters"
    if cost.run_s > MAX_SECONDS:
        return f"at most {_time(MAX_SECONDS)}"
    if cost.memory > MAX_MEMORY:
        return f"at most {MAX_MEMORY / 1e9:.0f} GB"
    return None


#: how to bring a cost down, for the messages
ADVICE = "use fewer bags, elements, modes or steps"


def refusal(cost: Cost) -> str | None:
    """The message for a scenario over the limits (no file name, no key), or None."""
    why = over(cost)
    if why is None:
        return None
    return f"too large ({why}): {cost.text()} estimated; {ADVICE}"


def check(scenario, bags: int | None = None, where: str = "scenario") -> Cost:
    """:func:`estimate` and refuse (:class:`InputError`, one line) beyond the limits."""
    cost = estimate(scenario, bags=bags)
    msg = refusal(cost)
    if msg is not None:
        raise InputError.from_line(f"{where}: {msg}")
    return cost


def check_modes(elements: int, modes: int | None, where: str) -> float:
    """Refuse ``flexlift modes`` (dry and wet modes: two solves) estimated beyond
    :data:`MAX_SECONDS`; its estimate [s]."""
    k = min(stage_modes(elements, modes), 2 * elements + 2)
    t = 2.0 * modes_seconds(elements, k)
    if t > MAX_SECONDS:
        raise InputError.from_line(
            f"{where}: too large to compute: {k:,} modes of {elements:,} elements, about "
            f"{_time(t)} estimated; at most {_time(MAX_SECONDS)}: ask for fewer modes "
            "(--modes) or elements")
    return t


def expected_run_s(scenario) -> float:
    """How long an ascent run until held takes, roughly [s], for ``duration_s: auto``: the
    breakout (about five breakout times at the default pull), the rise at the planned speed
    and the hold (the tanker: 2,000 + 1,500 + 600 = 4,100 s against 4,046 s simulated)."""
    c, sim = scenario.control, scenario.simulation
    return (5.0 * scenario.seabed.breakout_time_s + c.target_height_m / c.ascent_speed_m_s
            + sim.hold_time_s)
