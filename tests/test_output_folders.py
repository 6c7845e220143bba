"""Output folders (issue 10 §2): flexlift replaces only what it wrote, atomically, one run at a
time, recovering what killed runs left, with ordinary permissions."""

import json
import os
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from flexlift.cli import main
from flexlift.output import MARKER, OutputError, output_folder
from flexlift.output.folders import OLD, PARTIAL, read_marker
from flexlift.plumbing.atomic import write_text as _write
from flexlift.plumbing.marker import JOURNAL


def _one_line(capsys, needle: str) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert needle in lines[0], lines[0]
    return lines[0]


def _litter(parent: Path) -> list[str]:
    return sorted(n for n in os.listdir(parent) if PARTIAL in n or OLD in n or n.endswith(".lock"))


@pytest.fixture
def users_folder(tmp_path):
    d = tmp_path / "thesis"
    (d / "chapter").mkdir(parents=True)
    (d / "draft.tex").write_text("years of work")
    (d / "chapter" / "one.tex").write_text("more work")
    return d


def test_run_refuses_a_folder_of_the_users_files_and_touches_nothing(users_folder, capsys):
    before = sorted(p.relative_to(users_folder).as_posix() for p in users_folder.rglob("*"))
    assert main(["run", "--out", str(users_folder), "--quiet", "--stages", "modes"]) == 2
    line = _one_line(capsys, str(users_folder))
    assert "did not write" in line and "new or empty folder" in line
    after = sorted(p.relative_to(users_folder).as_posix() for p in users_folder.rglob("*"))
    assert after == before and (users_folder / "draft.tex").read_text() == "years of work"
    assert _litter(users_folder.parent) == []


@pytest.mark.parametrize("command", ["modes", "loads", "reduce", "fuzzy"])
def test_every_writing_command_uses_the_same_writer(command, users_folder, tmp_path, capsys):
    assert main([command, "--out", str(users_folder)]) == 2
    _one_line(capsys, "did not write")
    assert (users_folder / "draft.tex").exists()
    out = tmp_path / f"{command}-out"
    assert main([command, "--out", str(out), "--json"]) == 0
    marker = read_marker(out)
    assert marker["complete"] and marker["command"] == command
    assert "figures" in {Path(f).parts[0] for f in marker["files"]}
    # a second run replaces flexlift's own folder
    assert main([command, "--out", str(out), "--json"]) == 0
    assert read_marker(out)["run_id"] != marker["run_id"]
    assert _litter(tmp_path) == []


def test_simulate_writes_through_the_writer(users_folder, tmp_path, capsys):
    assert main(["simulate", "--duration", "5", "--out", str(users_folder), "--json"]) == 2
    _one_line(capsys, "did not write")
    out = tmp_path / "sim"
    assert main(["simulate", "--duration", "5", "--out", str(out), "--json"]) == 0
    assert (out / "results.nc").is_file() and (out / "tables").is_dir()
    assert read_marker(out)["command"] == "simulate"


def test_a_file_the_user_added_to_a_flexlift_folder_is_never_deleted(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["loads", "--out", str(out)]) == 0
    (out / "my-notes.txt").write_text("keep me")
    capsys.readouterr()
    assert main(["loads", "--out", str(out)]) == 2
    line = _one_line(capsys, "my-notes.txt")
    assert "did not write" in line
    assert (out / "my-notes.txt").read_text() == "keep me"


@pytest.mark.parametrize("target", [".", "..", "sub/.."])
def test_the_current_folder_and_its_parents_are_refused(target, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    assert main(["loads", "--out", target]) == 2
    _one_line(capsys, "current folder")
    assert sorted(os.listdir(tmp_path)) == ["sub"]


def test_a_target_that_is_a_file_or_under_a_file_is_one_line(tmp_path, capsys):
    f = tmp_path / "report.pdf"
    f.write_text("%PDF")
    assert main(["modes", "--out", str(f)]) == 2
    _one_line(capsys, "is a file")
    assert main(["modes", "--out", str(f / "sub")]) == 2
    _one_line(capsys, "could not be written")
    assert f.read_text() == "%PDF"


def test_a_symlinked_target_is_refused(tmp_path, capsys):
    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "link").symlink_to(real)
    assert main(["loads", "--out", str(tmp_path / "link")]) == 2
    _one_line(capsys, "symbolic link")


def test_an_empty_folder_of_the_user_may_be_used(tmp_path):
    out = tmp_path / "empty"
    out.mkdir()
    assert main(["loads", "--out", str(out)]) == 0
    assert read_marker(out)["complete"]


def test_a_write_error_is_one_line_and_the_previous_output_is_intact(tmp_path, capsys,
                                                                     monkeypatch):
    out = tmp_path / "o"
    assert main(["run", "--out", str(out), "--quiet", "--stages", "modes,loads"]) == 0
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    import flexlift.plumbing.atomic as files

    real = files.write_text

    def full_disk(path, text):
        if str(path).endswith("report.html"):
            raise OSError(28, "No space left on device", str(path))
        return real(path, text)

    monkeypatch.setattr("flexlift.cli.run.write_text", full_disk)
    capsys.readouterr()
    assert main(["run", "--out", str(out), "--quiet", "--stages", "modes,loads"]) == 2
    line = _one_line(capsys, "No space left on device")
    assert "previous output is left as it was" in line
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert _litter(tmp_path) == []


def test_a_second_run_on_a_locked_folder_is_refused(tmp_path, capsys):
    out = tmp_path / "o"
    with output_folder(out, "run") as tmp:
        _write(tmp / "x.txt", "first run")
        assert main(["loads", "--out", str(out)]) == 2
        _one_line(capsys, "another flexlift run")
    assert (out / "x.txt").read_text() == "first run"
    assert _litter(tmp_path) == []


def test_an_exception_while_building_leaves_the_previous_output(tmp_path):
    out = tmp_path / "o"
    with output_folder(out, "run") as tmp:
        _write(tmp / "a.txt", "v1")
    with pytest.raises(KeyboardInterrupt), output_folder(out, "run") as tmp:
        _write(tmp / "a.txt", "v2")
        raise KeyboardInterrupt
    assert (out / "a.txt").read_text() == "v1"
    assert _litter(tmp_path) == []


def _leftover(parent: Path, name: str, kind: str, tag: str, complete: bool, content: str):
    d = parent / f".{name}{kind}{tag}"
    d.mkdir()
    (d / "a.txt").write_text(content)
    files = ["a.txt"] if complete else []
    if not complete:  # a killed run journaled the name before it created the file
        (d / JOURNAL).write_text(json.dumps("a.txt") + "\n")
    (d / MARKER).write_text(json.dumps({"flexlift_output": 1, "run_id": tag, "complete": complete,
                                        "files": files}))
    return d


def test_recovery_after_a_kill_while_building(tmp_path, caplog):
    out = tmp_path / "o"
    with output_folder(out, "run") as tmp:
        _write(tmp / "a.txt", "v1")
    _leftover(tmp_path, "o", PARTIAL, "killed", complete=False, content="half")
    with output_folder(out, "run") as tmp:
        _write(tmp / "a.txt", "v2")
    assert (out / "a.txt").read_text() == "v2"
    assert _litter(tmp_path) == []
    assert any("removed 1 unfinished" in r.getMessage() for r in caplog.records)


def test_recovery_after_a_kill_inside_the_swap(tmp_path, caplog):
    # killed between moving the old output aside and moving the new one in: the next run
    # finishes the swap (the new output was complete), so nothing is missing and no litter
    _leftover(tmp_path, "o", OLD, "a", complete=True, content="v1")
    _leftover(tmp_path, "o", PARTIAL, "b", complete=True, content="v2")
    with output_folder(tmp_path / "o", "run") as tmp:
        # the recovered folder is in place while the new run builds
        assert (tmp_path / "o" / "a.txt").read_text() == "v2"
        _write(tmp / "a.txt", "v3")
    assert (tmp_path / "o" / "a.txt").read_text() == "v3"
    assert _litter(tmp_path) == []
    assert any("finished the swap" in r.getMessage() for r in caplog.records)


def test_recovery_restores_the_previous_output_when_the_new_was_unfinished(tmp_path, caplog):
    _leftover(tmp_path, "o", OLD, "a", complete=True, content="v1")
    _leftover(tmp_path, "o", PARTIAL, "b", complete=False, content="half")
    with pytest.raises(OutputError), output_folder(tmp_path / "o", "run"):
        raise OSError(5, "Input/output error")
    assert (tmp_path / "o" / "a.txt").read_text() == "v1"
    assert _litter(tmp_path) == []
    assert any("restored the previous output" in r.getMessage() for r in caplog.records)


def test_recovery_never_touches_hidden_folders_that_are_not_flexlifts(tmp_path):
    mine = tmp_path / ".o.partial-mine"  # the user's, by coincidence of name: no marker
    mine.mkdir()
    (mine / "keep.txt").write_text("x")
    with output_folder(tmp_path / "o", "run") as tmp:
        _write(tmp / "a.txt", "v1")
    assert (mine / "keep.txt").read_text() == "x"


def test_permissions_are_for_archiving_not_private(tmp_path):
    old = os.umask(0o022)
    try:
        out = tmp_path / "o"
        assert main(["loads", "--out", str(out)]) == 0
    finally:
        os.umask(old)
    assert stat.S_IMODE(out.stat().st_mode) == 0o755
    for p in out.rglob("*"):
        want = 0o755 if p.is_dir() else 0o644
        assert stat.S_IMODE(p.stat().st_mode) == want, p


def _start(out: Path, tmp_path: Path, figure_processes: str = "") -> subprocess.Popen:
    env = dict(os.environ, MPLBACKEND="Agg", FLEXLIFT_FIGURE_PROCESSES=figure_processes)
    return subprocess.Popen([sys.executable, "-m", "flexlift", "run", "--out", str(out), "--quiet"],
                            cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True)


def _wait_for_partial(tmp_path: Path, name: str, proc: subprocess.Popen) -> None:
    t0 = time.monotonic()
    while not any(n.startswith(f".{name}{PARTIAL}") for n in os.listdir(tmp_path)):
        assert proc.poll() is None and time.monotonic() - t0 < 60, "the run never started"
        time.sleep(0.05)
    time.sleep(0.5)  # let it write a little


def _wait_for_a_figure(tmp_path: Path, proc: subprocess.Popen) -> None:
    """Until the run's partial folder holds a figure (the figure processes are running)."""
    t0 = time.monotonic()
    while not any(tmp_path.glob(f".o{PARTIAL}*/figures/*.png")):
        assert proc.poll() is None and time.monotonic() - t0 < 60, "no figure drawn"
        time.sleep(0.05)


@pytest.mark.parametrize("figure_processes", ["0", "2"])
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_a_killed_run_leaves_the_previous_output_and_no_litter(sig, figure_processes,
                                                               tmp_path):
    """Killed while it draws (in the main process, or with two figure processes: none of
    them is left behind holding the run's output pipe, or writing into its folder). A run
    that finished its last figure and swapped its folder in before the signal arrived (the
    signal follows the first figure by up to one poll; a fast run on a loaded machine can
    beat it) tested nothing: it is run again, at most twice."""
    out = tmp_path / "o"
    for _ in range(3):
        with output_folder(out, "run") as tmp:
            _write(tmp / "previous.txt", "v1")
        proc = _start(out, tmp_path, figure_processes)
        _wait_for_partial(tmp_path, "o", proc)
        _wait_for_a_figure(tmp_path, proc)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
        finished = not (out / "previous.txt").exists() and (out / "report.html").is_file()
        if not finished:
            break
    else:
        pytest.fail("the run finished before its signal three times: nothing was tested")
    assert (out / "previous.txt").read_text() == "v1"
    if sig == signal.SIGTERM:  # cleaned up at once, and said so on one line
        assert proc.returncode == 143 and "terminated" in err and "Traceback" not in err
        assert _litter(tmp_path) == []
    else:  # SIGKILL: nothing can run; the next run on that folder cleans up
        assert any(PARTIAL in n for n in _litter(tmp_path))
        with output_folder(out, "run") as tmp:
            _write(tmp / "previous.txt", "v2")
        assert _litter(tmp_path) == []


def test_an_incremental_folder_removes_only_its_own_unchanged_files(tmp_path):
    """remove_own (the sweep's stale rerun files): listed, a regular file, and holding what
    the command wrote; an edited file, a link in its place or an unlisted file stays."""
    from flexlift.output.folders import incremental_folder
    from flexlift.plumbing.atomic import write_text

    out = tmp_path / "o"
    with incremental_folder(out, "sweep", "id-1") as inc:
        inc.claim("a.yaml", "b.yaml", "c.yaml")
        for name in ("a.yaml", "b.yaml", "c.yaml"):
            write_text(out / name, f"{name}\n")
    (out / "b.yaml").write_text("edited by the user\n")
    with incremental_folder(out, "sweep", "id-1") as inc:
        (out / "c.yaml").unlink()  # (a link at open is refused outright; here one appears later)
        (out / "c.yaml").symlink_to(out / "a.yaml")
        assert inc.remove_own("a.yaml", b"a.yaml\n")
        assert not inc.remove_own("b.yaml", b"b.yaml\n")  # edited: the user's now
        assert not inc.remove_own("c.yaml", b"a.yaml\n")  # a link in its place
        assert not inc.remove_own("d.yaml", b"")  # never listed
    assert not (out / "a.yaml").exists()
    assert (out / "b.yaml").read_text() == "edited by the user\n"
    assert (out / "c.yaml").is_symlink()
