"""The compiled functions' on-disk cache (flexlift._jit): a change to any compiled module
recompiles what inlines it, through numba's public cache option only, in the folder the user
chose, and nothing outside the decoration sees that option changed."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numba
import pytest

from flexlift import _jit

SRC = Path(__file__).resolve().parents[1] / "src"

#: a compiled function in one module that inlines a law of another (as the loop does)
_PROBE = '''
from flexlift._jit import jit
from flexlift.physics.gas import buoyancy


@jit
def probe(volume):
    return buoyancy(volume, 1.0)
'''

_CALL = "from flexlift.physics._probe import probe; print(probe(2.0))"


def _copy(tmp_path: Path) -> Path:
    """The package copied to ``tmp_path/src`` (no caches) with the probe added."""
    dest = tmp_path / "src" / "flexlift"
    shutil.copytree(SRC / "flexlift", dest,
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc"))
    (dest / "physics" / "_probe.py").write_text(_PROBE)
    return dest


def _run(tmp_path: Path, cache_dir: Path | None = None) -> float:
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    env.update(PYTHONPATH=str(tmp_path / "src"), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    if cache_dir is not None:
        env["NUMBA_CACHE_DIR"] = str(cache_dir)
    res = subprocess.run([sys.executable, "-c", _CALL], env=env, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 0, res.stderr
    return float(res.stdout.strip())


def _indexes(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.rglob("*.nbi"))


def test_a_changed_law_recompiles_what_inlines_it(tmp_path):
    """The probe's own file is unchanged, the law it inlines changes: numba alone would load
    the stale probe (its cache is stamped with its own file); here it is recompiled."""
    package = _copy(tmp_path)
    assert _run(tmp_path) == 2.0
    first = list((package / "__pycache__").glob(f"{_jit.PREFIX}*"))
    assert len(first) == 1 and any(n.startswith("_probe.probe") for n in _indexes(first[0]))
    assert _run(tmp_path) == 2.0  # from the cache: same folder, nothing new
    assert list((package / "__pycache__").glob(f"{_jit.PREFIX}*")) == first
    gas = package / "physics" / "gas.py"
    text = gas.read_text()
    assert text.count("return rho_g * volume") == 1
    gas.write_text(text.replace("return rho_g * volume", "return 3.0 * rho_g * volume"))
    assert _run(tmp_path) == 6.0
    assert len(list((package / "__pycache__").glob(f"{_jit.PREFIX}*"))) == 2


def test_the_users_numba_cache_dir_is_respected(tmp_path):
    """NUMBA_CACHE_DIR set: flexlift's cache goes below it (stamped), not beside the
    sources."""
    package = _copy(tmp_path)
    user = tmp_path / "user-cache"
    assert _run(tmp_path, user) == 2.0
    folders = list((user / "flexlift").glob(f"{_jit.PREFIX}*"))
    assert len(folders) == 1 and any(n.startswith("_probe.probe") for n in _indexes(folders[0]))
    assert not list((package / "__pycache__").glob(f"{_jit.PREFIX}*"))


def test_numba_cache_option_is_set_only_while_decorating(tmp_path, monkeypatch):
    """Other numba functions of the process keep the user's cache folder: the option is
    back to what it was after each decoration, and a function decorated by flexlift keeps
    its own folder."""
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "theirs"))
    monkeypatch.setattr(_jit, "_FOLDER", tmp_path / "ours")
    (tmp_path / "ours").mkdir()

    def twice(x):
        return 2 * x

    compiled = _jit.jit(twice)
    assert numba.config.CACHE_DIR == str(tmp_path / "theirs")
    if numba.config.DISABLE_JIT:
        pytest.skip("NUMBA_DISABLE_JIT: nothing is compiled")
    assert compiled(3.0) == 6.0
    assert any(p.suffix == ".nbi" for p in (tmp_path / "ours").rglob("*"))
    assert not (tmp_path / "theirs").exists()


def test_a_read_only_place_is_skipped(tmp_path):
    """The first writable base is used (a read-only install: the user's folder); none
    writable: no cache at all (numba would fall back to its own, unstamped one)."""
    blocked = tmp_path / "a-file"
    blocked.write_text("not a folder")  # nothing can be made below it, not even by root
    ok = tmp_path / "ok"
    folder = _jit.cache_folder("ab" * 32, [blocked / "flexlift", ok])
    assert folder == ok / f"{_jit.PREFIX}{'ab' * 8}" and folder.is_dir()
    assert _jit.cache_folder("ab" * 32, [blocked / "x", blocked / "y"]) is None


def test_old_cache_folders_are_pruned(tmp_path):
    """A new folder removes those of other stamps older than a day and all but the newest
    KEEP of the others; other files in the base are left alone."""
    now = time.time()
    ages = {"old": 2 * 86400, **{f"recent{k}": 60 * (k + 1) for k in range(_jit.KEEP + 1)}}
    for name, age in ages.items():
        p = tmp_path / f"{_jit.PREFIX}{name}"
        p.mkdir()
        os.utime(p, (now - age, now - age))
    (tmp_path / "someone-elses").mkdir()
    folder = _jit.cache_folder("cd" * 32, [tmp_path])
    left = sorted(p.name for p in tmp_path.iterdir())
    kept = [f"{_jit.PREFIX}recent{k}" for k in range(_jit.KEEP)]
    assert left == sorted([folder.name, "someone-elses", *kept])
    _jit.cache_folder("cd" * 32, [tmp_path])  # an existing folder prunes nothing
    assert sorted(p.name for p in tmp_path.iterdir()) == left


def test_the_stamp_covers_every_compiled_module(tmp_path):
    """A change to a law, the kernel or the compiler switch changes the stamp."""
    package = _copy(tmp_path)
    before = _jit.sources_stamp(package)
    assert before == _jit.sources_stamp(package)
    for rel in ("physics/seabed.py", "ascent/kernel.py", "control/controller.py", "_jit.py",
                "fuzzy/tables.py"):
        f = package / rel
        text = f.read_text()
        f.write_text(text + "\n# changed\n")
        assert _jit.sources_stamp(package) != before, rel
        f.write_text(text)
    assert _jit.sources_stamp(package) == before


def test_the_warm_check_finds_the_loop_numba_wrote(tmp_path, monkeypatch):
    """cache_is_warm() names the loop's real entry point: after one ascent it is True (a
    renamed entry point would leave it False for ever, and the first-run note on every run)."""
    import flexlift._jit as jit_module
    from flexlift import load_scenario
    from flexlift._jit import cache_is_warm
    from flexlift.ascent import simulate

    simulate(load_scenario("tanker"), duration=1.0)
    assert cache_is_warm()
    monkeypatch.setattr(jit_module, "_FOLDER", tmp_path)  # an empty cache folder
    assert not cache_is_warm()


_INTERPRETED = '''
import json, sys
import numpy as np
from flexlift import load_scenario
from flexlift.ascent import simulate
ds = simulate(load_scenario("tanker"), duration=20.0).dataset
print(json.dumps({v: np.asarray(ds[v].values, dtype=float).ravel().tolist()
                  for v in ("height", "gas_volume", "sling_force", "net_flow")}))
'''


def test_the_loop_runs_interpreted_under_numba_disable_jit():
    """``NUMBA_DISABLE_JIT=1`` runs the loop as Python (the structs become namespaces of the
    same arrays) and gives the compiled loop's numbers."""
    import json

    import numpy as np

    runs = []
    for disable in ("0", "1"):
        env = {**os.environ, "PYTHONPATH": str(SRC), "NUMBA_DISABLE_JIT": disable}
        out = subprocess.run([sys.executable, "-c", _INTERPRETED], env=env, capture_output=True,
                             text=True, timeout=600)
        assert out.returncode == 0, out.stderr[-2000:]
        runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
    for name, values in runs[0].items():
        np.testing.assert_allclose(runs[1][name], values, rtol=1e-9, atol=1e-9, err_msg=name)
