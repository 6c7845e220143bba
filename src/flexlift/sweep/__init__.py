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

import importlib

__all__ = ["SweepResult", "SweepSpec", "load_spec", "parse_spec", "run_sweep"]
#: where each name lives; imported when first asked for, so that importing a light module of
#: the package (:mod:`.executors`, to start the worker pool first thing) imports nothing else
_HOME = {"SweepResult": "run", "run_sweep": "run", "SweepSpec": "spec", "load_spec": "spec",
         "parse_spec": "spec"}


def __getattr__(name: str):
    if name in _HOME:
        return getattr(importlib.import_module(f"flexlift.sweep.{_HOME[name]}"), name)
    raise AttributeError(f"module 'flexlift.sweep' has no attribute {name!r}")


def __dir__():
    return sorted([*globals(), *__all__])
