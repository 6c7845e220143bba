"""One function per stage of the analysis, returning data (:class:`~flexlift.output.stage.
StageOutput`: summary, figures, tables, warnings, criteria): what the CLI, a notebook or a
sweep calls. Each stage writes its figures and tables into a folder when given one.

- :func:`flexlift.stages.modes.run_stage`, :func:`flexlift.stages.loads.run_stage`,
  :func:`flexlift.stages.reduce.run_stage`, :func:`flexlift.stages.fuzzy.run_stage`,
  :func:`flexlift.stages.simulate.run_stage`;
- :func:`flexlift.stages.run.run_all`: all of them, for ``flexlift run``.
"""
