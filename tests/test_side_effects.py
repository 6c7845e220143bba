"""A library call changes nothing process-wide: importing flexlift and running a stage (as a
notebook would) leaves logging, the cycle collector, numba's options, matplotlib's backend
and the process's children as they were, and forks nothing; the CLI's settings last only as
long as its command."""

from __future__ import annotations

import io
import json
import logging
import os
import signal
import subprocess
import sys

from flexlift.cli import main

_NOTEBOOK = r"""
import gc, json, logging, multiprocessing, os, signal, sys
from pathlib import Path

import matplotlib
import numba

forks = []
os.register_at_fork(before=lambda: forks.append(1))
frozen = []  # the freeze count at each collection during the call
gc.callbacks.append(lambda phase, info: frozen.append(gc.get_freeze_count()))

def state():
    lg = logging.getLogger("flexlift")
    return {"flexlift": [[type(h).__name__ for h in lg.handlers], lg.level, lg.propagate,
                         lg.disabled],
            "root": [[type(h).__name__ for h in logging.root.handlers], logging.root.level],
            "gc": [gc.isenabled(), gc.get_freeze_count(), list(gc.get_threshold())],
            "children": len(multiprocessing.active_children()),
            "signals": [repr(signal.getsignal(s)) for s in (signal.SIGINT, signal.SIGTERM)],
            "numba_cache_dir": numba.config.CACHE_DIR,
            "matplotlib_backend": matplotlib.get_backend()}

before = state()
from flexlift import load_scenario
from flexlift.stages.run import run_all

out = Path(sys.argv[1])
out.mkdir()
outputs = run_all(load_scenario("tanker"), out, stages=("modes",))
after = state()
print(json.dumps({"before": before, "after": after, "forks": len(forks),
                  "frozen_max": max(frozen, default=0), "collections": len(frozen),
                  "figures": sorted(p.name for p in (out / "figures").glob("*.png"))}))
"""


def test_a_stage_run_from_python_changes_nothing_process_wide(tmp_path):
    """With figure processes asked for by the environment, a library call still draws every
    figure itself (no fork) and never freezes the collector; afterwards logging, the
    collector, the signal handlers, numba's cache option, matplotlib's backend (a notebook's
    own; svg here, as Agg is what flexlift draws with) and the children are as before."""
    env = dict(os.environ, MPLBACKEND="svg", FLEXLIFT_FIGURE_PROCESSES="2")
    res = subprocess.run([sys.executable, "-c", _NOTEBOOK, str(tmp_path / "out")], env=env,
                         capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr
    seen = json.loads(res.stdout.strip().splitlines()[-1])
    assert seen["after"] == seen["before"]
    assert seen["forks"] == 0
    assert seen["collections"] > 0 and seen["frozen_max"] == 0
    assert seen["figures"] and all(n.startswith("modes_") for n in seen["figures"])


def _logger_state():
    lg = logging.getLogger("flexlift")
    return list(lg.handlers), lg.level, lg.propagate


def test_the_cli_gives_the_logger_back_as_the_caller_had_it(tmp_path, capsys):
    """main() called from Python: during the command the CLI's handlers only; afterwards the
    caller's own handler, level and propagation, whether the command succeeded or failed,
    and SIGTERM's handler as it was."""
    lg = logging.getLogger("flexlift")
    saved = _logger_state()
    mine = logging.StreamHandler(io.StringIO())
    lg.addHandler(mine)
    lg.setLevel(logging.ERROR)
    lg.propagate = True
    try:
        before = _logger_state()
        term = signal.getsignal(signal.SIGTERM)
        assert main(["-v", "modes", "--elements", "20", "--out", str(tmp_path / "m")]) == 0
        assert _logger_state() == before and signal.getsignal(signal.SIGTERM) == term
        assert main(["modes", str(tmp_path / "no-such.yaml")]) == 2
        assert _logger_state() == before
        assert mine.stream.getvalue() == ""  # the command's records went to its own handlers
    finally:
        lg.removeHandler(mine)
        lg.handlers[:] = saved[0]
        lg.setLevel(saved[1])
        lg.propagate = saved[2]
    capsys.readouterr()
