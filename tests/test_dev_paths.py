"""`./dev run` runs where the user stands: the scenario path and --out are the caller's, a
missing file is named by the absolute path looked at (issue 27)."""

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def dev():
    if not (ROOT / ".venv" / ".flexlift-run").is_file():
        pytest.skip("needs the repository's .venv (./dev test makes it)")
    return str(ROOT / "dev")


def test_dev_run_reads_and_writes_relative_to_the_callers_folder(tmp_path, dev):
    shutil.copy(ROOT / "src" / "flexlift" / "scenarios" / "tanker.yaml", tmp_path / "my-wreck.yaml")
    env = {**os.environ, "MPLBACKEND": "Agg"}
    done = subprocess.run([dev, "run", "my-wreck.yaml", "--out", "results", "--stages", "modes",
                           "--quiet"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=900, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert (tmp_path / "results" / "report.html").is_file()
    assert not (ROOT / "results").exists()


def test_a_missing_scenario_is_named_by_the_path_looked_at(tmp_path, dev):
    done = subprocess.run([dev, "run", "nowhere.yaml", "--stages", "modes"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 2
    last = done.stderr.strip().splitlines()[-1]
    assert f"looked for {tmp_path / 'nowhere.yaml'}" in last
