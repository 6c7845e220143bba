"""What a non-editable install gets: the wheel and the sdist built from this tree (setuptools,
offline, no build isolation) hold every file flexlift reads from its own package (the
scenarios, the data, the dashboard's page), and flexlift imported from the unpacked wheel alone
serves the dashboard's page, not an empty one."""

from __future__ import annotations

import shutil
import subprocess
import sys
import tarfile
import textwrap
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "flexlift"
#: the dashboard's files the page needs
STATIC = ("index.html", "dashboard.css", "dashboard.js")


def _data_files() -> set[str]:
    """Every file of the package that is not Python source or a cache, as flexlift/..."""
    return {p.relative_to(PACKAGE.parent).as_posix() for p in PACKAGE.rglob("*")
            if p.is_file() and p.suffix not in (".py", ".pyc")
            and "__pycache__" not in p.parts and not any(s.endswith(".egg-info") for s in p.parts)}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The wheel and the sdist of a copy of this tree (``pyproject.toml``, ``src``)."""
    tree = tmp_path_factory.mktemp("tree")
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, tree / name)
    shutil.copytree(ROOT / "src", tree / "src",
                    ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    dist = tree / "dist"
    dist.mkdir()
    code = ("import sys; from setuptools import build_meta as b; out = sys.argv[1]; "
            "b.build_wheel(out); b.build_sdist(out)")  # build_meta rewrites sys.argv
    done = subprocess.run([sys.executable, "-c", code, str(dist)], cwd=tree, timeout=120,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    (wheel,), (sdist,) = dist.glob("*.whl"), dist.glob("*.tar.gz")
    return wheel, sdist


def test_the_dashboards_files_are_package_data():
    assert {f"flexlift/live/dashboard/static/{n}" for n in STATIC} <= _data_files()


def test_the_wheel_and_the_sdist_hold_every_data_file(built):
    wheel, sdist = built
    in_wheel = set(zipfile.ZipFile(wheel).namelist())
    missing = _data_files() - in_wheel
    assert not missing, f"not in the wheel: {sorted(missing)}"
    with tarfile.open(sdist) as tar:
        in_sdist = {n.split("/src/", 1)[-1] for n in tar.getnames() if "/src/" in n}
    missing = _data_files() - in_sdist
    assert not missing, f"not in the sdist: {sorted(missing)}"


def test_flexlift_from_the_wheel_alone_serves_the_dashboards_page(built, tmp_path):
    """The wheel unpacked (what pip installs of a pure-Python wheel) is the only flexlift on
    the path: importlib.resources finds the page there and the dashboard serves it whole."""
    site = tmp_path / "site"
    zipfile.ZipFile(built[0]).extractall(site)
    probe = textwrap.dedent(f"""
        import sys, urllib.request
        from importlib import resources
        import flexlift
        assert flexlift.__file__.startswith({str(site)!r}), flexlift.__file__
        static = resources.files("flexlift.live.dashboard") / "static"
        for name in {STATIC!r}:
            assert (static / name).is_file(), name
        from flexlift.live.dashboard import Dashboard
        with Dashboard(port=0) as board:
            page = urllib.request.urlopen(board.url, timeout=5).read()
            script = urllib.request.urlopen(board.url + "static/dashboard.js", timeout=5).read()
        print(len(page), len(script), b"static/dashboard.js" in page)
    """)
    env = {"PYTHONPATH": str(site), "PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    done = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path, env=env, timeout=60,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    page, script, links = done.stdout.split()
    assert int(page) == len((PACKAGE / "live/dashboard/static/index.html").read_bytes())
    assert int(script) == len((PACKAGE / "live/dashboard/static/dashboard.js").read_bytes())
    assert links == "True"
