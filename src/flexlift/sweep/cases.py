"""The cases of a sweep: the product of a grid, or Monte Carlo samples.

Case ``i`` of a Monte Carlo draws its randomness from ``SeedSequence(seed).spawn(N)[i]``
(built directly as ``SeedSequence(seed, spawn_key=(i,))``, the same sequence): its first child
gives the uniform numbers of plain Monte Carlo, its second the case's noise seed
(``disturbance.seed``, used when the scenario has force noise; not set when the SPEC fixes or
varies it). A Latin hypercube stratifies all N cases together (``scipy.stats.qmc``'s), its
design drawn from ``SeedSequence(seed)`` itself. Either way the cases are made here, in the
process that runs the sweep, so the results are the same whatever the engine and the number
of workers, and case ``i`` of plain Monte Carlo is the same whatever N.

Run until a half-width (``until_halfwidth``), a Latin hypercube is drawn in blocks of
``block`` cases, block ``b`` its own hypercube from the third child of ``SeedSequence(seed,
spawn_key=(b,))``, so a sweep can stop at any block's end and still be made of whole
hypercubes. ``sobol`` is Saltelli's design (SALib, :mod:`flexlift.sweep.sobol`): N base
samples, each followed by its rows with one group's values swapped (N x (groups + 2)).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from flexlift.scenario import Scenario
from flexlift.sweep.spec import SweepSpec

NAME_MAX = 100


@dataclass(frozen=True)
class Case:
    """One case: its index, the values of the varied keys, and its noise seed (or None)."""

    index: int
    values: dict
    seed: int | None = None


def case_name(spec: SweepSpec, index: int) -> str:
    """``case_0042``: zero-padded to the width of the largest index (at least 4 digits)."""
    width = max(4, len(str(max(spec.n_cases - 1, 0))))
    return f"case_{index:0{width}d}"


def case_sequence(seed: int, index: int) -> np.random.SeedSequence:
    """Case ``index``'s own ``SeedSequence(seed).spawn(N)[index]``."""
    return np.random.SeedSequence(seed, spawn_key=(index,))


def make_cases(spec: SweepSpec) -> list[Case]:
    """Every case of ``spec``, in order."""
    if spec.method == "grid":
        keys = spec.keys
        return [Case(i, dict(zip(keys, combo)))
                for i, combo in enumerate(itertools.product(*spec.grid.values()))]
    u = uniforms(spec)
    columns = {k: d.ppf(u[:, j]) for j, (k, d) in enumerate(spec.distributions.items())}
    noise = "disturbance.seed" not in spec.fixed and "disturbance.seed" not in columns
    out = []
    for i in range(spec.n_cases):
        seed = _noise_seed(spec.seed, i) if noise else None
        out.append(Case(i, {k: col[i] for k, col in columns.items()}, seed))
    return out


def uniforms(spec: SweepSpec) -> np.ndarray:
    """(N, number of keys) numbers in [0, 1): a Latin hypercube or plain Monte Carlo."""
    n, d = spec.n_cases, len(spec.distributions)
    if spec.method == "sobol":
        from flexlift.sweep.sobol import saltelli_design

        return saltelli_design(list(spec.distributions), spec.groups, spec.samples, spec.seed)
    if spec.method == "lhs" and spec.block:
        blocks = [_lhs(d, min(spec.block, n - b0),
                       case_sequence(spec.seed, b0 // spec.block).spawn(3)[2])
                  for b0 in range(0, n, spec.block)]
        return np.concatenate(blocks) if blocks else np.empty((0, d))
    if spec.method == "lhs":
        return _lhs(d, n, np.random.SeedSequence(spec.seed))
    out = np.empty((n, d))
    for i in range(n):
        child = case_sequence(spec.seed, i).spawn(2)[0]
        out[i] = np.random.default_rng(child).random(d)
    return out


def _lhs(d: int, n: int, sequence: np.random.SeedSequence) -> np.ndarray:
    """``scipy.stats.qmc.LatinHypercube(d, rng=default_rng(sequence)).random(n)`` (SciPy
    >= 1.15, scrambled, strength 1), computed here: the same numbers (the tests compare them)
    without importing ``scipy.stats`` (0.7 s of a sweep's start). The engine draws from the
    first child of the generator's seed sequence: a uniform jitter per point, then one
    shuffle of the strata per dimension."""
    child = np.random.default_rng(sequence).bit_generator.seed_seq.spawn(1)[0]
    rng = np.random.Generator(np.random.PCG64(child))
    jitter = rng.uniform(size=(n, d))
    perms = np.tile(np.arange(1, n + 1), (d, 1))
    for i in range(d):
        rng.shuffle(perms[i, :])
    return (perms.T - jitter) / n


def _noise_seed(seed: int, index: int) -> int:
    child = case_sequence(seed, index).spawn(2)[1]
    return int(child.generate_state(1, np.uint64)[0] >> np.uint64(1))


def changes(spec: SweepSpec, case: Case) -> dict:
    """The dotted changes that turn the base scenario into ``case``'s."""
    out = dict(case.values)
    if spec.study is not None:
        from flexlift.sweep.studies import study_changes

        out = study_changes(spec.study, out)
    if case.seed is not None:
        out["disturbance.seed"] = case.seed
    suffix = case_name(spec, case.index)
    out["name"] = f"{spec.base.name[: NAME_MAX - len(suffix) - 1]}-{suffix}"
    return out


def case_scenario(spec: SweepSpec, case: Case) -> Scenario:
    """The scenario of ``case`` (an :class:`~flexlift.errors.InputError` when the combination
    of values is not a valid scenario)."""
    return spec.base.with_changes(**changes(spec, case))
