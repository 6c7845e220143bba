"""Imported first in a process flexlift starts for its own work (the sweep's fork server,
:class:`flexlift.sweep.executors.Processes`), before numpy loads there: one BLAS thread per
process (:func:`flexlift._threads.pin_worker_environment`), the workers being one per core
already. Never imported in the user's own process: it sets that process's environment."""

from flexlift._threads import pin_worker_environment

pin_worker_environment()
