"""flexlift: raise a sunken flexible hull with controlled lift bags.

The analysis flows one way, one stage per module:

    scenario -> hull -> beam -> modes -> liftplan/loads -> statespace -> reduce
             -> fuzzy/control + bags/seabed/hydro -> simulate -> results -> plots/report

The packages are floors; each imports only from the floors below it (tests/test_layout.py
holds the same list and checks every import against it):

    layers: plumbing, physics, scenario, structure, loads, dynamics, fuzzy, control, ascent,
            output, stages, sweep, cli

``plumbing`` (files written atomically, files read within bounds, the output lock and the
marker) is the bottom floor every layer may use; the top-level helpers (``constants``,
``errors``, ``_jit``, ``_struct``, ``_threads``) likewise.

One function joins the floors the other way: :func:`loaded`, the scenario as every way in
loads it (the library's ``load_scenario``, the command line, a sweep's base), chooses the
default bag of a user's hull on its lift plan (``flexlift.loads.clusters``), which the
scenario floor cannot compute.

Units are SI throughout (m, s, kg, N, Pa, rad); tonnes, degrees and bar appear only in
scenario files and reports.
"""

__all__ = ["__version__", "loaded"]


def __getattr__(name: str):
    """``__version__``, looked up when first asked for: importing :mod:`importlib.metadata`
    takes 40 ms, paid before a sweep can start its worker pool (the command line imports this
    package first)."""
    if name != "__version__":
        raise AttributeError(f"module 'flexlift' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("flexlift")
    except PackageNotFoundError:  # running from a source tree without installation
        value = "0+unknown"
    globals()["__version__"] = value
    return value


def loaded(scenario):
    """``scenario`` as every way in loads it: a user's hull without a bag choice given the
    largest standard bag whose clusters fit (:func:`flexlift.loads.clusters.with_default_bag`);
    any other scenario as it is. :func:`flexlift.scenario.load_scenario` returns this."""
    if (scenario.defaulted or {}).get("lift.catalogue_bag") != "derived":
        return scenario
    from flexlift.loads.clusters import with_default_bag

    return with_default_bag(scenario)
