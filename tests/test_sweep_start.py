"""The sweep's fixed start and end (issue 28): what the coordinator and the fork server import.

Each check runs in a new interpreter (what is imported is a property of the process)."""

import subprocess
import sys

import pytest


def _run(code: str) -> list[str]:
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=180)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout.split()


def test_one_command_builds_only_its_own_parser():
    code = ("import sys, flexlift.cli as c\n"
            "p = c.build_parser('sweep')\n"
            "a = p.parse_args(['sweep', 's.yaml', '--workers', '2'])\n"
            "print(a.command, a.workers, int('flexlift.ascent' in sys.modules),\n"
            "      int('flexlift.stages.modes' in sys.modules))\n"
            "full = c.build_parser()\n"
            "print(sorted(full._subparsers._group_actions[0].choices) == sorted(c.COMMANDS))\n"
            "print(sorted(c.build_parser('nosuch')._subparsers._group_actions[0].choices)\n"
            "      == sorted(c.COMMANDS))\n")
    assert _run(code) == ["sweep", "2", "0", "0", "True", "True"]


def test_the_results_import_nothing_the_coordinator_did_not_import_meanwhile():
    """With TAIL_MODULES imported (while the workers run), building and writing results.nc
    in :func:`without_dask` imports nothing more, and no Dask at all (xarray asks for
    dask.array and distributed when Dask is installed); xarray is as it was afterwards."""
    pytest.importorskip("dask")
    code = ("import importlib, sys, numpy as np\n"
            "from flexlift.sweep.run import TAIL_MODULES\n"
            "from flexlift.sweep.nodask import GUARDED, without_dask\n"
            "for m in TAIL_MODULES:\n"
            "    importlib.import_module(m)\n"
            "import xarray as xr, tempfile, os\n"
            "from xarray.namedarray import pycompat\n"
            "fns = [getattr(importlib.import_module(m), n) for m, n, _ in GUARDED]\n"
            "before = set(sys.modules)\n"
            "with without_dask():\n"
            "    ds = xr.Dataset({'a': ('case', np.arange(3.0))}, coords={'case': [0, 1, 2]})\n"
            "    with tempfile.TemporaryDirectory() as d:\n"
            "        ds.to_netcdf(os.path.join(d, 'r.nc'), engine='scipy')\n"
            "        back = xr.open_dataset(os.path.join(d, 'r.nc'), engine='scipy').load()\n"
            "new = sorted(m for m in set(sys.modules) - before\n"
            "             if m.split('.')[0] in ('dask', 'distributed', 'matplotlib'))\n"
            "print(len(new), *new[:5], back['a'].values.tolist() == [0.0, 1.0, 2.0])\n"
            "print(fns == [getattr(importlib.import_module(m), n) for m, n, _ in GUARDED],\n"
            "      'dask' in pycompat._cached_duck_array_modules)\n")
    assert _run(code) == ["0", "True", "True", "False"]


def test_with_dask_imported_xarray_asks_dask_as_before():
    """Once Dask is imported (a Dask engine), :func:`without_dask` changes nothing: with
    DASK_TAIL imported meanwhile, the results import no more of Dask; a Dask array is one."""
    pytest.importorskip("dask")
    code = ("import importlib, sys, numpy as np\n"
            "from flexlift.sweep.run import DASK_TAIL, TAIL_MODULES\n"
            "from flexlift.sweep.nodask import without_dask\n"
            "for m in TAIL_MODULES + DASK_TAIL:\n"
            "    importlib.import_module(m)\n"
            "import xarray as xr, tempfile, os, dask.array as da\n"
            "before = set(sys.modules)\n"
            "with without_dask():\n"
            "    ds = xr.Dataset({'a': ('case', np.arange(3.0))})\n"
            "    lazy = xr.Dataset({'a': ('case', da.arange(3.0, chunks=1))})\n"
            "    with tempfile.TemporaryDirectory() as d:\n"
            "        ds.to_netcdf(os.path.join(d, 'r.nc'), engine='scipy')\n"
            "new = sorted(m for m in set(sys.modules) - before\n"
            "             if m.split('.')[0] in ('dask', 'distributed'))\n"
            "print(len(new), *new[:5], lazy.chunks is not None and len(lazy.chunks) > 0)\n")
    assert _run(code) == ["0", "True"]


def test_a_guarded_question_goes_to_xarray_once_dask_is_imported():
    """:func:`forget_dask` answers xarray's questions about Dask objects only while Dask is
    not imported: once it is, xarray's own code answers them."""
    pytest.importorskip("dask")
    code = ("import sys\n"
            "from flexlift.sweep.nodask import forget_dask\n"
            "print(int(forget_dask()))\n"
            "from xarray.namedarray import utils\n"
            "print(int(utils.is_dask_collection(1)), int('dask' in sys.modules))\n"
            "import dask\n"
            "print(int(utils.is_dask_collection(dask.delayed(1))),\n"
            "      int(utils.is_dask_collection(1)))\n")
    assert _run(code) == ["1", "0", "0", "1", "0"]


def test_the_command_line_starts_the_pool_before_asking_for_its_version():
    """The version comes from importlib.metadata (40 ms to import) when first asked for, not
    on importing the package: the command line imports the package and starts a sweep's
    fork server before anything asks."""
    code = ("import sys, flexlift.cli, flexlift.sweep.executors\n"
            "print(int('importlib.metadata' in sys.modules))\n"
            "from importlib.metadata import version\n"
            "import flexlift\n"
            "print(int(flexlift.__version__ == version('flexlift')))\n"
            "try:\n"
            "    flexlift.no_such_name\n"
            "except AttributeError as exc:\n"
            "    print('AttributeError', int('no_such_name' in str(exc)))\n")
    assert _run(code) == ["0", "1", "AttributeError", "1"]


def test_the_fork_server_imports_no_dask_and_freezes_its_objects():
    """The warm-up (the fork server's preload) records summaries only: it imports neither
    xarray, pandas nor Dask; its objects are frozen (the workers never scan them), and so are
    those left at its exit (an atexit handler of flexlift._worker_process). A worker of its
    own that keeps histories builds its Datasets without importing Dask either."""
    pytest.importorskip("dask")
    code = ("import atexit, gc, sys, numpy as np\n"
            "atexit.register(lambda: print('exit', int(gc.get_freeze_count() > 10000)))\n"
            "import flexlift._worker_process\n"
            "from flexlift.sweep.warm import WARM\n"
            "print(int(WARM), *(int(m in sys.modules) for m in ('dask', 'xarray', 'pandas')),\n"
            "      int(gc.get_freeze_count() > 10000))\n"
            "gc.unfreeze()\n"
            "from flexlift import load_scenario\n"
            "from flexlift.sweep import worker\n"
            "worker.own_process()\n"
            "task = worker.Task(0, load_scenario('tanker'), {}, ('coordinated',), True)\n"
            "record, datasets = worker.run_case(task)\n"
            "print(int('dask' in sys.modules), type(datasets['coordinated']).__name__,\n"
            "      record['results']['coordinated']['outcome'])\n")
    # flexlift.sweep.warm warms the loop on import (its job in the fork server): a few seconds
    assert _run(code) == ["1", "0", "0", "0", "1", "0", "Dataset", "safe", "exit", "1"]


def test_a_command_exits_without_collecting_its_heap():
    """The command line's process freezes its objects at exit (an atexit handler, once)
    instead of collecting them while its modules are torn down (0.6-0.8 s of a sweep)."""
    code = ("import atexit, gc\n"
            "atexit.register(lambda: print('exit', int(gc.get_freeze_count() > 1000)))\n"
            "from flexlift.cli import main\n"
            "import contextlib, io\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    main(['--version']); main(['--version'])\n"
            "print(int(gc.get_freeze_count() == 0))\n")
    assert _run(code) == ["1", "exit", "1"]


def test_the_coordinator_reads_a_spec_without_xarray_or_scipy():
    """Reading a SPEC, drawing its cases and pricing them import neither xarray (the
    results' module, imported while the cases run) nor scipy.special (only the normal laws
    need it)."""
    code = ("import sys\n"
            "from flexlift.sweep import parse_spec\n"
            "from flexlift.sweep.run import estimate_sweep\n"
            "from flexlift.sweep.cases import make_cases\n"
            "spec = parse_spec({'base': 'tanker', 'control': 'coordinated', 'monte_carlo': {\n"
            "    'samples': 8, 'seed': 1, 'vary': {\n"
            "        'seabed.breakout_time_s': {'dist': 'loguniform', 'low': 200, 'high': 800},\n"
            "        'disturbance.current_m_s': {'dist': 'uniform', 'low': -0.2, 'high': 0.2}}}})\n"
            "cases = make_cases(spec)\n"
            "per, total = estimate_sweep(spec, 2)\n"
            "print(len(cases), int(total > 0), *(int(m in sys.modules) for m in\n"
            "      ('xarray', 'pandas', 'scipy.special', 'numba')))\n")
    assert _run(code) == ["8", "1", "0", "0", "0", "0"]


def test_a_summary_case_is_written_without_loading_the_ascent():
    """The coordinator of a ``keep: summary`` sweep never imports the ascent package (its
    compiled code's module, a second or more at the first case)."""
    code = ("import sys, tempfile, json\n"
            "from flexlift.sweep import parse_spec\n"
            "from flexlift.sweep.store import SweepFolder\n"
            "spec = parse_spec({'base': 'tanker', 'control': 'coordinated',\n"
            "                   'grid': {'seabed.breakout_time_s': [200, 400]}})\n"
            "with tempfile.TemporaryDirectory() as d:\n"
            "    with SweepFolder.open(d + '/out', spec) as folder:\n"
            "        rec = folder.write_case('case_0000', {'case': 0, 'status': 'completed',\n"
            "                                              'results': {}}, {})\n"
            "        on_disk = json.loads(folder.case_path('case_0000').read_text())\n"
            "print(int('flexlift.ascent' in sys.modules), int('numba' in sys.modules),\n"
            "      on_disk == rec, rec['histories'])\n")
    assert _run(code) == ["0", "0", "True", "[]"]


def test_a_copy_computes_aside_or_says_it_cannot():
    """:func:`flexlift.sweep.aside.start`: the value computed by a forked copy; None where a
    thread runs besides the main one (forking would be unsafe); a copy that fails or takes
    too long gives None, and is ended and reaped (no process left behind)."""
    if not sys.platform.startswith("linux"):
        pytest.skip("the copy is forked on Linux only")
    code = ("import os, threading, time\n"
            "from flexlift.sweep import aside\n"
            "a = aside.start(lambda x: {'twice': 2 * x, 'pid': os.getpid()}, 21)\n"
            "r = a.result()\n"
            "print(r['twice'], int(r['pid'] != os.getpid()))\n"
            "print(aside.start(lambda: 1 / 0).result())\n"
            "slow = aside.start(time.sleep, 30)\n"
            "t = time.monotonic(); print(slow.result(limit_s=0.5), int(time.monotonic() - t < 5))\n"
            "try:\n"
            "    os.kill(slow.pid or 0, 0) if slow.pid else None\n"
            "    print('ended', int(slow.pid is None))\n"
            "except ProcessLookupError:\n"
            "    print('ended', 1)\n"
            "stop = threading.Event()\n"
            "th = threading.Thread(target=stop.wait); th.start()\n"
            "print(aside.start(lambda: 1)); stop.set(); th.join()\n")
    assert _run(code) == ["42", "1", "None", "None", "1", "ended", "1", "None"]


def test_the_report_drawn_aside_is_the_report_drawn_here():
    """The sweep's report with its figures drawn by a forked copy is byte for byte the
    report drawn in one process (but the time it states); the copy drew them."""
    if not sys.platform.startswith("linux"):
        pytest.skip("the copy is forked on Linux only")
    code = ("import re, tempfile\n"
            "from flexlift.sweep import aside, parse_spec, run_sweep\n"
            "from flexlift.sweep import run\n"
            "from flexlift.sweep.cases import case_name, make_cases\n"
            "from flexlift.sweep.executors import Serial\n"
            "from flexlift.sweep.store import SweepFolder\n"
            "spec = parse_spec({'base': 'tanker', 'control': 'coordinated',\n"
            "                   'set': {'simulation.duration_s': 50}, 'monte_carlo': {\n"
            "    'samples': 12, 'seed': 2, 'vary': {'seabed.breakout_time_s':\n"
            "        {'dist': 'uniform', 'low': 200, 'high': 800}}}})\n"
            "cases = make_cases(spec)\n"
            "names = {c.index: case_name(spec, c.index) for c in cases}\n"
            "drawn = []\n"
            "start = aside.start\n"
            "def counted(fn, makers):\n"
            "    copy = start(fn, makers)\n"
            "    drawn.append(sorted(makers) if copy is not None else None)\n"
            "    return copy\n"
            "aside.start = counted\n"
            "pages = []\n"
            "with tempfile.TemporaryDirectory() as d:\n"
            "    result = run_sweep(spec, d + '/out', engine=Serial())\n"
            "    with SweepFolder.open(d + '/out', spec) as folder:\n"
            "        for can in (True, False):\n"
            "            aside.can_fork = aside.spare_core = (lambda c=can: c)\n"
            "            run._write_results(result, cases, names, folder)\n"
            "            text = (folder.path / 'report.html').read_text()\n"
            "            pages.append(re.sub(r'\\d{4}-\\d\\d-\\d\\d \\d\\d:\\d\\d UTC', '', text))\n"
            "print(int(pages[0] == pages[1]), int(pages[0].count('data:image/png') >= 2), drawn[-1])\n")
    assert _run(code) == ["1", "1", "['cdfs',", "'tornado:coordinated']"]


def test_a_copy_is_made_only_with_a_core_to_spare(monkeypatch):
    """The sweep's end forks its copy only while fewer threads are ready to run than this
    process has cores (/proc/loadavg's running count, this process's included)."""
    import builtins
    import io
    import os

    from flexlift.sweep import aside

    real_open = builtins.open
    loadavg = {"text": ""}

    def fake_open(path, *args, **kwargs):
        if path == "/proc/loadavg":
            return io.StringIO(loadavg["text"])
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", fake_open)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1}, raising=False)
    seen = []
    for running in (1, 2, 5):
        loadavg["text"] = f"0.50 0.40 0.30 {running}/321 4567\n"
        seen.append(aside.spare_core())
    loadavg["text"] = "garbled\n"
    seen.append(aside.spare_core())
    assert seen == [True, False, False, False]
