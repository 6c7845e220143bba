"""All stages on one scenario, for ``flexlift run``: their outputs and the run's summary.

:func:`run_all` changes nothing in the calling process beyond its output folder: it draws
every figure in this process and leaves the cycle collector alone. What makes ``flexlift run``
fast is the caller's to choose, around the call (the CLI does both)::

    from flexlift.output.plots._style import figures_in_background
    with heap_frozen(), figures_in_background():  # figure processes where two cores are free
        outputs = run_all(scenario, out)
"""

from __future__ import annotations

import contextlib
import gc
import importlib
import typing
from pathlib import Path

from flexlift import __version__
from flexlift.output.report import STAGE_TITLES
from flexlift.output.stage import StageOutput
from flexlift.scenario import ControlMode
from flexlift.scenario.basis import design_basis

STAGES = ("modes", "loads", "reduce", "fuzzy", "simulate")
CONTROL_MODES = typing.get_args(ControlMode)
DEFAULT_CONTROLS = ("decentralized", "coordinated")


class _Silent:
    """A progress display that shows nothing."""

    def stage(self, k: int, n: int, text: str) -> None:
        pass

    def bar(self, fraction: float, label: str = "") -> None:
        pass


def run_all(
    scenario,
    out: Path,
    stages: tuple[str, ...] = STAGES,
    controls: tuple[str, ...] = DEFAULT_CONTROLS,
    progress=None,
) -> list[StageOutput]:
    """Run ``stages`` into the folder ``out`` (already created); return their outputs.
    ``progress``: an object with ``stage(k, n, text)`` and ``bar(fraction, label)`` (the CLI's
    progress display), or None. The figures are drawn in this process, or by the figure
    processes of a :func:`~flexlift.output.plots._style.figures_in_background` block the
    caller has opened (module docstring)."""
    return _run_stages(scenario, out, stages, controls, progress or _Silent())


@contextlib.contextmanager
def heap_frozen():
    """Within the block, the cycle collector leaves alone every object that existed before it
    (:func:`gc.freeze`; released again at its end, :func:`gc.unfreeze`). The imports (numpy,
    scipy, xarray, numba, matplotlib) leave a few hundred thousand objects that the collector
    otherwise walks at every full collection: three of them during a run of the tanker took
    about 1 s, a seventh of the run. Garbage of the run itself is collected as usual. The
    collector is the whole process's: ``flexlift run`` enters this block around
    :func:`run_all`, which itself never does."""
    if gc.get_freeze_count():  # frozen by a caller: theirs to release
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def _run_stages(scenario, out: Path, stages, controls, progress) -> list[StageOutput]:
    outputs: list[StageOutput] = []
    n = len(stages)
    for k, name in enumerate(stages, start=1):
        module = importlib.import_module(f"flexlift.stages.{name}")
        title = STAGE_TITLES.get(name, name).split(". ", 1)[-1]
        if name == "simulate":
            progress.stage(k, n, f"{title}: {', '.join(controls)}")
            for mode in controls:
                outputs.append(
                    module.run_stage(
                        scenario,
                        out,
                        control=mode,
                        progress=lambda f, m=mode: progress.bar(f, m),
                    )
                )
            if len(controls) > 1:
                outputs.append(module.compare_stage(outputs[-len(controls):], out))
        else:
            progress.stage(k, n, title)
            outputs.append(module.run_stage(scenario, out))
    return outputs


#: the outcomes of an ascent from the worst (ascent/outcome.py)
OUTCOME_ORDER = ("unsafe", "not_achieved", "incomplete", "safe")


def summary_of(scenario, outputs: list[StageOutput], elapsed_s: float) -> dict:
    """summary.json: the headline numbers of every stage under the stage's name."""
    stages: dict = {}
    for o in outputs:
        if o.name.startswith("simulate:"):
            stages.setdefault("simulate", {})[o.name.split(":", 1)[1]] = o.summary
        elif o.name != "compare":
            stages[o.name] = o.summary
    criteria = {f"{o.name}.{k}": bool(v) for o in outputs for k, v in o.criteria.items()}
    outcomes = {m: s.get("outcome") for m, s in stages.get("simulate", {}).items()}
    return {
        "flexlift_version": __version__,
        "scenario": scenario.name,
        "scenario_checksum": scenario.checksum(),
        "elapsed_s": round(elapsed_s, 2),
        # the decision: the worst outcome of the control modes simulated (None: none simulated)
        "outcome": next((k for k in OUTCOME_ORDER if k in outcomes.values()), None),
        "outcomes": outcomes,
        "all_criteria_passed": all(criteria.values()) if criteria else None,
        "criteria": criteria,
        "warnings": [w for o in outputs for w in o.warnings],
        # every factor, limit and assumed value with its source (scenario/basis.py)
        "design_basis": design_basis(scenario),
        "stages": stages,
    }
