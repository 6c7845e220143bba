"""flexlift: raise a sunken flexible hull with controlled lift bags.

The analysis flows one way, one stage per module:

    scenario -> hull -> beam -> modes -> liftplan/loads -> statespace -> reduce
             -> fuzzy/control + bags/seabed/hydro -> simulate -> results -> plots/report

The packages are floors; each imports only from the floors below it (tests/test_layout.py
holds the same list and checks every import against it):

    layers: plumbing, physics, scenario, structure, loads, dynamics, fuzzy, control, ascent,
            sensors, estimate, output, live, stages, sweep, design, cli

``plumbing`` (files written atomically, files read within bounds, the output lock and the
marker) is the bottom floor every layer may use; the top-level helpers (``constants``,
``errors``, ``_jit``, ``_struct``, ``_threads``) likewise.

``flexlift.load_scenario`` (:func:`flexlift.loads.scenario.load_scenario`) loads a scenario
as every way in does: the file read on the scenario floor, then a user's hull given its
default bag on its lift plan, on the loads floor.

Units are SI throughout (m, s, kg, N, Pa, rad); tonnes, degrees and bar appear only in
scenario files and reports.
"""

__all__ = ["__version__", "load_scenario"]


def __getattr__(name: str):
    """``__version__``, looked up when first asked for: importing :mod:`importlib.metadata`
    takes 40 ms, paid before a sweep can start its worker pool (the command line imports this
    package first)."""
    if name == "load_scenario":  # looked up when first asked for, as the version is
        from flexlift.loads.scenario import load_scenario

        return load_scenario
    if name != "__version__":
        raise AttributeError(f"module 'flexlift' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("flexlift")
    except PackageNotFoundError:  # running from a source tree without installation
        value = "0+unknown"
    globals()["__version__"] = value
    return value
