"""Sweeps and Monte Carlo (docs/theory/sweeps.md): many ascents of one base scenario, and what they add
up to.

- :mod:`.spec`: the SPEC file (a base scenario, fixed overrides, a grid or a Monte Carlo);
  :mod:`.keys` the dotted keys it may use, :mod:`.distributions` the laws it may sample;
- :mod:`.cases`: the cases, their values and their seeds (``SeedSequence(seed).spawn``);
- :mod:`.worker`: one case's ascents reduced to a record; :mod:`.executors`: where the cases
  run (this process, local processes, a Dask cluster);
- :mod:`.store`: the resumable output folder; :mod:`.run`: :func:`run_sweep`;
- :mod:`.aggregate`: failure probabilities (Wilson), influences (rank correlation), the
  dataset; :mod:`.report` and :mod:`.plots`: the HTML report.

``run_sweep(load_spec("sweep.yaml"), "out")`` runs (or resumes) a sweep.
"""

from flexlift.sweep.run import SweepResult, run_sweep
from flexlift.sweep.spec import SweepSpec, load_spec, parse_spec

__all__ = ["SweepResult", "SweepSpec", "load_spec", "parse_spec", "run_sweep"]
