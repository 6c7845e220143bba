"""The lock file beside an output folder: never opened through a link, never a file flexlift did
not create (issue: a planted ``.out.lock`` made every writing command overwrite a user's file);
and what a killed run leaves is removed by its listing, never by the look of a name."""

import json
import os
import subprocess
import sys

import pytest

from flexlift.cli import main
from flexlift.output import MARKER, OutputError, output_folder
from flexlift.output.folders import PARTIAL, incremental_folder
from flexlift.plumbing.atomic import write_text
from flexlift.plumbing.lock import CONTENT, held_lock, lock_path
from flexlift.plumbing.marker import JOURNAL


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def _one_line(capsys, *needles):
    err = capsys.readouterr().err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in lines[0], lines[0]


def _open(kind, out):
    """Open ``out`` the way a command of ``kind`` does (built aside, or written in place)."""
    if kind == "aside":
        return output_folder(out, "modes")
    return incremental_folder(out, "sweep", "id")


# --------------------------------------------------------------------------- planted things
@pytest.mark.parametrize("kind", ["aside", "in-place"])
def test_a_symlink_at_the_lock_name_is_refused_and_its_target_untouched(tmp_path, kind):
    notes = tmp_path / "notes.txt"
    notes.write_text("precious")
    (tmp_path / ".out.lock").symlink_to(notes)
    with pytest.raises(OutputError, match="symbolic link"), _open(kind, tmp_path / "out"):
        pass
    assert notes.read_text() == "precious"
    assert (tmp_path / ".out.lock").is_symlink()  # not removed either
    assert not (tmp_path / "out").exists()


def test_the_cli_refuses_a_planted_lock_link_in_one_line(tmp_path, capsys):
    notes = tmp_path / "notes.txt"
    notes.write_text("precious")
    (tmp_path / ".out.lock").symlink_to(notes)
    assert main(["loads", "--out", str(tmp_path / "out")]) == 2
    _one_line(capsys, ".out.lock", "symbolic link")
    assert notes.read_text() == "precious"


@pytest.mark.parametrize("kind", ["aside", "in-place"])
def test_a_hard_link_at_the_lock_name_is_refused(tmp_path, kind):
    notes = tmp_path / "notes.txt"
    notes.write_text(f"{CONTENT} {_dead_pid()}")  # even with a lock's content
    os.link(notes, tmp_path / ".out.lock")
    with pytest.raises(OutputError, match="2 hard links"), _open(kind, tmp_path / "out"):
        pass
    assert notes.read_text().startswith(CONTENT)
    assert (tmp_path / ".out.lock").exists()


@pytest.mark.parametrize("content", ["my own notes", "", f"{CONTENT} 12x", f"{CONTENT}  7"])
def test_a_users_file_at_the_lock_name_is_kept(tmp_path, content):
    mine = tmp_path / ".out.lock"
    mine.write_text(content)
    with pytest.raises(OutputError, match="not a flexlift lock"), _open("aside", tmp_path / "out"):
        pass
    assert mine.read_text() == content


def test_a_fifo_or_a_folder_at_the_lock_name_is_left(tmp_path):
    os.mkfifo(tmp_path / ".a.lock")
    (tmp_path / ".b.lock").mkdir()
    with pytest.raises(OutputError, match="FIFO"), _open("aside", tmp_path / "a"):
        pass
    with pytest.raises(OutputError, match="folder"), _open("aside", tmp_path / "b"):
        pass
    assert (tmp_path / ".a.lock").exists() and (tmp_path / ".b.lock").is_dir()


def test_a_lock_naming_a_live_process_is_refused(tmp_path):
    lock = tmp_path / ".out.lock"
    lock.write_text(f"{CONTENT} {os.getppid()}")  # alive, but not holding the flock
    with pytest.raises(OutputError, match="which is running"), _open("aside", tmp_path / "out"):
        pass
    assert lock.read_text() == f"{CONTENT} {os.getppid()}"


# --------------------------------------------------------------------------- flexlift's own
@pytest.mark.parametrize("kind", ["aside", "in-place"])
def test_the_stale_lock_of_a_killed_run_is_replaced(tmp_path, kind):
    lock = tmp_path / ".out.lock"
    lock.write_text(f"{CONTENT} {_dead_pid()}")
    with _open(kind, tmp_path / "out"):
        assert lock.read_text() == f"{CONTENT} {os.getpid()}"
    assert not lock.exists()  # the run's own lock, removed at its end


def test_a_killed_runs_lock_file_is_replaced_by_the_next_run(tmp_path):
    """A real run killed with SIGKILL while it holds the lock: the next run goes ahead."""
    code = ("import os, sys, time\n"
            "from flexlift.output import output_folder\n"
            f"with output_folder({str(tmp_path / 'out')!r}, 'modes'):\n"
            "    print('locked', flush=True); time.sleep(60)\n")
    p = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline().strip() == "locked"
        assert lock_path(tmp_path / "out").read_text() == f"{CONTENT} {p.pid}"
        with pytest.raises(OutputError, match=f"pid {p.pid}"), _open("aside", tmp_path / "out"):
            pass  # alive and holding it: refused
        p.kill()
        p.wait(timeout=30)
    finally:
        p.kill()
    with _open("aside", tmp_path / "out") as tmp:
        write_text(tmp / "a.txt", "after")
    assert (tmp_path / "out" / "a.txt").read_text() == "after"
    assert not lock_path(tmp_path / "out").exists()


def test_runs_on_different_folders_of_one_parent_never_block_each_other(tmp_path):
    with output_folder(tmp_path / "a", "modes") as a, output_folder(tmp_path / "b", "modes") as b:
        write_text(a / "x.txt", "a")
        write_text(b / "x.txt", "b")
    assert (tmp_path / "a" / "x.txt").read_text() == "a"
    assert (tmp_path / "b" / "x.txt").read_text() == "b"


def test_a_lock_replaced_under_a_run_is_not_removed_by_it(tmp_path):
    """The run removes its lock at the end only if the name still refers to its own file."""
    final = tmp_path / "out"
    with held_lock(final, OutputError) as path:
        os.unlink(path)
        path.write_text("someone else's")
    assert path.read_text() == "someone else's"


# --------------------------------------------------------------------------- ownership by list
def test_a_users_file_in_a_killed_runs_partial_folder_is_kept(tmp_path, caplog):
    out = tmp_path / "out"
    with output_folder(out, "modes") as tmp:
        write_text(tmp / "a.txt", "v1")
    killed = tmp_path / f".out{PARTIAL}killed"
    killed.mkdir()
    (killed / MARKER).write_text(json.dumps({"flexlift_output": 1, "complete": False,
                                             "files": []}))
    (killed / JOURNAL).write_text(json.dumps("half.txt") + "\n" + json.dumps("plots") + "\n")
    (killed / "half.txt").write_text("ours, cut short")
    (killed / "plots").mkdir()
    (killed / "plots" / "mine.txt").write_text("the user's")  # listed nowhere
    (killed / "also-mine.txt").write_text("the user's too")
    with output_folder(out, "modes") as tmp:
        write_text(tmp / "a.txt", "v2")
    assert not (killed / "half.txt").exists()  # listed: removed
    assert (killed / "plots" / "mine.txt").read_text() == "the user's"
    assert (killed / "also-mine.txt").read_text() == "the user's too"
    assert any("did not write" in r.message and killed.name in r.message for r in caplog.records)


def test_a_link_in_a_killed_runs_partial_folder_is_never_followed(tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "x.png").write_text("the user's")
    killed = tmp_path / f".out{PARTIAL}killed"
    killed.mkdir()
    (killed / MARKER).write_text(json.dumps({"flexlift_output": 1, "complete": False,
                                             "files": []}))
    (killed / JOURNAL).write_text(json.dumps("plots") + "\n" + json.dumps("plots/x.png") + "\n")
    (killed / "plots").symlink_to(elsewhere)  # a listed folder replaced by a link
    with output_folder(tmp_path / "out", "modes"):
        pass
    assert (elsewhere / "x.png").read_text() == "the user's"


def test_every_name_a_run_writes_is_journaled_before_it_exists(tmp_path, monkeypatch):
    """Kill a run between journaling a name and creating it: the leftover is listed."""
    import flexlift.plumbing.atomic as atomic

    seen = []
    real = atomic.claim

    def spy(*paths):
        real(*paths)
        for p in paths:
            seen.append((p.name, p.exists()))

    monkeypatch.setattr(atomic, "claim", spy)
    with output_folder(tmp_path / "out", "modes") as tmp:
        write_text(tmp / "sub" / "a.txt", "x")
        journal = (tmp / JOURNAL).read_text()
    first = {}
    for name, existed in seen:
        first.setdefault(name, existed)
    assert first and not any(first.values())  # each claimed before it first existed
    names = [json.loads(line) for line in journal.splitlines()]
    assert "sub" in names and "sub/a.txt" in names
    assert any(n.startswith("sub/.a.txt.") and n.endswith(".tmp") for n in names)  # its temporary
    assert not (tmp_path / "out" / JOURNAL).exists()  # the finished folder has none


@pytest.mark.parametrize("command", [["loads"], ["statics"]], ids=["loads", "statics"])
def test_a_commands_own_output_is_replaced_by_its_rerun(tmp_path, command):
    """Every file and folder a command writes is listed, so its rerun replaces the folder."""
    out = tmp_path / "out"
    assert main([*command, "--out", str(out)]) == 0
    marker = json.loads((out / MARKER).read_text())
    assert marker["complete"] and marker["files"]
    assert not (out / JOURNAL).exists()
    assert main([*command, "--out", str(out)]) == 0


def _small_figure(label):
    from matplotlib.figure import Figure

    fig = Figure()
    fig.add_subplot().set_title(label)
    return fig


def test_figure_processes_started_before_the_folder_journal_their_files(tmp_path):
    """A caller may open the figure processes first and the output folder inside: the figures
    the processes write are still listed, so the next run replaces the folder."""
    from flexlift.output.plots._style import draw, figures_in_background

    out = tmp_path / "out"
    with figures_in_background(2) as pool:
        assert pool is not None
        draw(tmp_path / "first.png", _small_figure, "started")  # the processes start here
        with output_folder(out, "modes") as tmp:
            draw(tmp / "figures" / "a.png", _small_figure, "a")
            pool.finish()
    marker = json.loads((out / MARKER).read_text())
    assert "figures/a.png" in marker["files"] and "figures" in marker["files"]
    with output_folder(out, "modes") as tmp:  # ours: replaced
        write_text(tmp / "b.txt", "b")
    assert sorted(os.listdir(out)) == [MARKER, "b.txt"]


def test_a_fifo_planted_as_a_case_record_never_blocks_a_resume(tmp_path):
    """The sweep reads its own case records without blocking: a FIFO is not a record."""
    import signal

    from flexlift.sweep.store import _read_json

    fifo = tmp_path / "case_0001.json"
    os.mkfifo(fifo)
    signal.signal(signal.SIGALRM, lambda *a: (_ for _ in ()).throw(TimeoutError("blocked")))
    signal.alarm(10)
    try:
        assert _read_json(fifo) is None
    finally:
        signal.alarm(0)
    (tmp_path / "real.json").write_text('{"case": 1}')
    assert _read_json(tmp_path / "real.json") == {"case": 1}
    (tmp_path / "link.json").symlink_to(tmp_path / "real.json")
    assert _read_json(tmp_path / "link.json") is None


def test_a_file_planted_as_a_sweeps_journal_is_never_written_or_removed(tmp_path):
    """A hard link to a user's file at the journal's name: the rerun is refused, the file
    keeps its content and its name."""
    out = tmp_path / "out"
    with incremental_folder(out, "sweep", "id") as inc:
        write_text(out / "a.txt", "ours")
        inc.finish()
    notes = tmp_path / "notes.txt"
    notes.write_text("precious")
    os.link(notes, out / JOURNAL)
    with pytest.raises(OutputError, match="not a flexlift journal"), \
            incremental_folder(out, "sweep", "id"):
        pass
    assert notes.read_text() == "precious" and (out / JOURNAL).exists()


def test_a_journal_replaced_during_the_run_is_not_appended_to(tmp_path):
    other = tmp_path / "elsewhere.txt"
    other.write_text("the user's")
    with pytest.raises(OutputError), output_folder(tmp_path / "out", "modes") as tmp:
        os.unlink(tmp / JOURNAL)
        os.link(other, tmp / JOURNAL)  # another file at the journal's name
        write_text(tmp / "a.txt", "x")
    assert other.read_text() == "the user's"
