"""Every supported Python installs the locks (issue 40): each pin's own Requires-Python admits
every supported version, pyproject's requires-python and ./dev say the same range, the run lock's
pins are the test lock's, and `./dev` on a Python too old refuses in one line (exit 2)."""

import json
import os
import re
import subprocess
import time
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
from packaging.specifiers import SpecifierSet
from packaging.version import Version

ROOT = Path(__file__).resolve().parents[1]
REQ = ROOT / "requirements"
TABLE = json.loads((REQ / "python-support.json").read_text())
SUPPORTED = [Version(v) for v in TABLE["supported"]]


def pins(lock: str) -> dict[str, str]:
    """{name: version} of a lock file's `name==version` lines."""
    found = re.findall(r"^([A-Za-z0-9._-]+)==([^\s\\;]+)", (REQ / lock).read_text(), re.M)
    return {name.lower().replace("_", "-"): version for name, version in found}


@pytest.mark.parametrize("lock", sorted(TABLE["locks"]))
def test_the_table_records_every_pin_of_the_lock_at_its_version(lock):
    table = {name: row["version"] for name, row in TABLE["locks"][lock].items()}
    assert table == pins(lock)


@pytest.mark.parametrize("lock", sorted(TABLE["locks"]))
def test_every_pins_requires_python_admits_every_supported_version(lock):
    refused = [(name, row["requires_python"], str(v))
               for name, row in TABLE["locks"][lock].items() if row["requires_python"]
               for v in SUPPORTED if v not in SpecifierSet(row["requires_python"])]
    assert refused == []


def test_a_pin_that_excludes_the_oldest_python_is_caught():
    # the check above on the pin that broke Debian 12 (pymdown-extensions 13.1.2)
    assert Version("3.11.2") not in SpecifierSet(">=3.11.5")
    assert Version(TABLE["supported"][0]) == Version("3.11.2")


def test_the_installed_distributions_agree_with_the_table():
    """The table against the wheels' own metadata, wherever the installed version is the pin."""
    checked = 0
    for name, row in TABLE["locks"]["test.lock"].items():
        try:
            dist = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue
        if dist.version != row["version"]:
            continue
        assert dist.metadata.get("Requires-Python") == row["requires_python"], name
        checked += 1
    if checked == 0:
        pytest.skip("none of the locked versions is installed here")


def test_the_run_lock_is_the_test_locks_pins_for_what_it_holds():
    run, test = pins("run.lock"), pins("test.lock")
    assert {name: test.get(name) for name in run} == run


def test_pyproject_and_dev_state_the_tested_range():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    spec = SpecifierSet(project["requires-python"])
    assert all(v in spec for v in SUPPORTED)
    assert Version("3.11.1") not in spec and Version("3.14.0") not in spec
    dev = (ROOT / "dev").read_text()
    assert f'PY_OLDEST="{TABLE["supported"][0]}"' in dev
    newest = ".".join(TABLE["supported"][-1].split(".")[:2])
    assert f'PY_NEWEST_MINOR="{newest}"' in dev


def fake_python(tmp_path: Path, version: str) -> Path:
    """A `python3` on a PATH of its own that reports VERSION and can do nothing else."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    fake = bin_dir / "python3"
    fake.write_text(f"#!/bin/sh\necho {version}\n")
    fake.chmod(0o755)
    return bin_dir


@pytest.mark.parametrize("version", ["3.10.13", "3.11.1", "3.14.0"])
def test_dev_on_an_unsupported_python_says_so_in_one_line(tmp_path, version):
    # a copy of ./dev in an empty folder: no .venv there, so the interpreter on the PATH is checked
    (tmp_path / "dev").write_text((ROOT / "dev").read_text())
    (tmp_path / "dev").chmod(0o755)
    path = f"{fake_python(tmp_path, version)}:/usr/bin:/bin"
    done = subprocess.run([str(tmp_path / "dev"), "run"], capture_output=True, text=True,
                          timeout=60, env={"PATH": path, "HOME": str(tmp_path)})
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert f"found Python {version}" in lines[0]
    assert "needs Python 3.11.2 to 3.13.x" in lines[0] and "PYTHON=" in lines[0]
    assert not (tmp_path / ".venv").exists()
    assert os.listdir(tmp_path) == ["dev", "bin"] or sorted(os.listdir(tmp_path)) == ["bin", "dev"]


def test_dev_with_no_python_at_all_says_so(tmp_path):
    (tmp_path / "dev").write_text((ROOT / "dev").read_text())
    (tmp_path / "dev").chmod(0o755)
    done = subprocess.run([str(tmp_path / "dev"), "test"], capture_output=True, text=True,
                          timeout=60, env={"PATH": "/usr/bin:/bin", "HOME": str(tmp_path),
                                           "PYTHON": str(tmp_path / "nope")})
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [done.stderr.strip()]
    assert "found no Python" in done.stderr


def test_a_failed_install_says_so_and_leaves_nothing_running(tmp_path):
    """pip failing (here: a lock naming a file that is not there) ends ./dev in one sentence with
    exit 1, and the background "still installing" line is stopped with it (issue 40: the trap
    failed under set -u and the ticker kept printing after the prompt had returned)."""
    import sys
    (tmp_path / "dev").write_text((ROOT / "dev").read_text())
    (tmp_path / "dev").chmod(0o755)
    (tmp_path / "requirements").mkdir()
    (tmp_path / "requirements" / "run.lock").write_text(
        f"{tmp_path / 'absent-0.0-py3-none-any.whl'} --hash=sha256:{'0' * 64}\n")
    (tmp_path / "pyproject.toml").write_text("")
    python = getattr(sys, "_base_executable", sys.executable)
    dev = subprocess.Popen([str(tmp_path / "dev"), "run"], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True,
                           env={"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "PYTHON": python})
    try:
        dev.wait(60)
        exited = time.monotonic()
        # nothing of ./dev (the ticker's sleep) holds its output open after it exits: a
        # caller reading it to its end (a pipe, $(...)) is not kept waiting
        stdout, stderr = dev.communicate(timeout=60)
        closed = time.monotonic() - exited
    finally:
        if dev.poll() is None:
            dev.kill()
            dev.communicate()
    done = subprocess.CompletedProcess(dev.args, dev.returncode, stdout, stderr)
    assert closed < 4.0, f"./dev's output stayed open {closed:.1f} s after it exited"
    assert done.returncode == 1, done.stderr
    assert "pip could not install requirements/run.lock" in done.stderr.strip().splitlines()[-1]
    assert "unbound variable" not in done.stderr
    left = subprocess.run(["pgrep", "-f", str(tmp_path / "dev")], capture_output=True, text=True)
    assert left.stdout.strip() == ""
