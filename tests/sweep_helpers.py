"""Workers that die, for the sweep's tests (imported by the worker processes by name)."""

import os
from pathlib import Path

from flexlift.sweep.worker import run_case

#: the case whose worker dies
DIE_CASE = 2


def dies_always(task):
    """A worker process that dies (as if killed) whenever it runs case DIE_CASE."""
    if task.index == DIE_CASE:
        os._exit(9)
    return run_case(task)


def dies_once(task):
    """A worker that dies the first time it runs case DIE_CASE (a flag file, named in the
    base scenario's description, remembers)."""
    flag = Path(task.base.description)
    if task.index == DIE_CASE and not flag.exists():
        flag.write_text("died")
        os._exit(9)
    return run_case(task)


class Substitute:
    """An engine that runs ``fn`` in place of the function the sweep submits."""

    def __init__(self, engine, fn):
        self.engine, self.fn = engine, fn
        self.name, self.workers, self.window = engine.name, engine.workers, engine.window

    def submit(self, fn, *args):
        return self.engine.submit(self.fn, *args)

    def close(self, cancel: bool = False):
        self.engine.close(cancel)


def bug_in_case(task):
    """A worker in which case DIE_CASE meets a programming error (a ZeroDivisionError where
    its plant is built), in whatever process or thread runs it; the other cases run as usual."""
    import threading

    import flexlift.sweep.plants as plants

    if task.index != DIE_CASE:
        return run_case(task)
    real, me = plants.plant_for, threading.get_ident()

    def broken(*args, **kwargs):
        if threading.get_ident() == me:
            return 1 / 0
        return real(*args, **kwargs)

    plants.plant_for = broken
    try:
        return run_case(task)
    finally:
        plants.plant_for = real
