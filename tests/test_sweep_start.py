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
    """With TAIL_MODULES imported (while the workers run), writing results.nc imports no
    more of Dask (xarray asks for dask.array and distributed when Dask is installed)."""
    pytest.importorskip("dask")
    code = ("import importlib, sys, numpy as np\n"
            "from flexlift.sweep.run import TAIL_MODULES\n"
            "for m in TAIL_MODULES:\n"
            "    try:\n        importlib.import_module(m)\n"
            "    except ImportError:\n        pass\n"
            "import xarray as xr, tempfile, os\n"
            "before = set(sys.modules)\n"
            "ds = xr.Dataset({'a': ('case', np.arange(3.0))})\n"
            "with tempfile.TemporaryDirectory() as d:\n"
            "    ds.to_netcdf(os.path.join(d, 'r.nc'), engine='scipy')\n"
            "new = sorted(m for m in set(sys.modules) - before\n"
            "             if m.split('.')[0] in ('dask', 'distributed', 'matplotlib'))\n"
            "print(len(new), *new[:5])\n")
    assert _run(code) == ["0"]


def test_the_fork_server_tells_xarray_no_dask_array_exists():
    pytest.importorskip("dask")
    code = ("import sys, numpy as np\n"
            "from flexlift.sweep.warm import WARM, no_dask_arrays\n"
            "print(int(WARM))\n"
            "import xarray as xr\n"
            "ds = xr.Dataset({'a': ('x', np.arange(3.0))}, coords={'x': [1, 2, 3]})\n"
            "print(int('dask.array' in sys.modules), ds['a'].values.tolist() == [0.0, 1.0, 2.0])\n"
            "import dask.array as da\n"
            "print(int(no_dask_arrays()))\n")
    # flexlift.sweep.warm warms the loop on import (its job in the fork server): a few seconds
    assert _run(code) == ["1", "0", "True", "0"]


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
