"""``flexlift design``: the plan searched for (docs/theory/design.md).

:mod:`.space` the candidates, :mod:`.bound` the lower bound, :mod:`.statics` and
:mod:`.dynamic` the ladder's rungs, :mod:`.cache` the evaluations kept, :mod:`.search` the
optimiser, :mod:`.run` the output folder, :mod:`.report` the report.
"""
