"""The plumbing removes only what flexlift wrote: a journal is replaced or removed only when
its content is a journal's; a FIFO under the journal's name fails a claim instead of blocking;
a failed atomic write removes its temporary only while the name is still that file."""

import os
import signal
from pathlib import Path

import pytest

from flexlift.plumbing import atomic
from flexlift.plumbing.marker import JOURNAL, Journal


def test_a_users_file_under_the_journals_name_is_never_replaced_or_removed(tmp_path):
    own = tmp_path / JOURNAL
    own.write_text("my notes\n")
    with pytest.raises(FileExistsError, match="not a list of names"):
        Journal(tmp_path).start()
    Journal(tmp_path).remove()
    assert own.read_text() == "my notes\n"


def test_a_journal_flexlift_wrote_is_replaced_and_removed(tmp_path):
    j = Journal(tmp_path).start()
    j.claim("a.txt", "figures/b.png")
    (tmp_path / JOURNAL).write_bytes((tmp_path / JOURNAL).read_bytes() + b'"torn')  # killed
    again = Journal(tmp_path).start()  # a journal left by an earlier run: replaced
    assert again.entries() == []
    again.claim("c.txt")
    Journal(tmp_path).remove()
    assert not (tmp_path / JOURNAL).exists()


def test_a_fifo_under_the_journals_name_fails_a_claim_without_blocking(tmp_path):
    j = Journal(tmp_path).start()
    os.unlink(tmp_path / JOURNAL)
    os.mkfifo(tmp_path / JOURNAL)
    signal.alarm(10)  # a regression blocks in open(): fail instead of hanging
    try:
        with pytest.raises(OSError):
            j.claim("x.txt")
    finally:
        signal.alarm(0)
    assert Path(tmp_path / JOURNAL).is_fifo()


def test_a_failed_write_leaves_a_file_that_replaced_its_temporary(tmp_path):
    target = tmp_path / "out.txt"
    with pytest.raises(RuntimeError):
        with atomic.atomic_file(target) as tmp:
            os.unlink(tmp)
            tmp.write_text("the user's")  # another file under the temporary's name
            raise RuntimeError("the write fails")
    assert tmp.read_text() == "the user's" and not target.exists()
    with pytest.raises(RuntimeError):
        with atomic.atomic_file(target) as tmp2:
            raise RuntimeError("the write fails")
    assert not tmp2.exists()  # its own temporary is removed


@pytest.mark.parametrize("planted", ["symlink", "hardlink", "new_file"])
def test_a_claim_writes_only_the_journal_the_run_created(tmp_path, planted):
    """A link or another file planted under the journal's name during a run: the claim fails
    and the file outside the output is untouched (the journal is opened without following a
    link, never created by a claim, and written only while it is the file start() made)."""
    outside = tmp_path / "outside.txt"
    outside.write_text("the user's\n")
    out = tmp_path / "out"
    out.mkdir()
    j = Journal(out).start()
    os.unlink(out / JOURNAL)
    if planted == "symlink":
        os.symlink(outside, out / JOURNAL)
    elif planted == "hardlink":
        os.link(outside, out / JOURNAL)
    else:
        (out / JOURNAL).write_text('"a.txt"\n')
    try:
        with pytest.raises(OSError):
            j.claim("x.txt")
    finally:
        j.close()
    assert outside.read_text() == "the user's\n"
    if planted == "new_file":
        assert (out / JOURNAL).read_text() == '"a.txt"\n'


def test_the_journal_is_let_go_at_the_end_of_the_run(tmp_path):
    from flexlift.plumbing.marker import journaled

    with journaled(tmp_path) as j:
        fd = j._fd
        os.fstat(fd)  # held during the run
    with pytest.raises(OSError):
        os.fstat(fd)  # closed after it


def test_the_run_that_made_the_journal_never_opens_its_name_again(tmp_path, monkeypatch):
    """Claims of the creating process go through the descriptor it holds (appended, after
    an adopted journal's lines), so no planted name can ever be opened by them."""
    j = Journal(tmp_path).start()
    other = Journal(tmp_path, j.ident)  # as an adopted journal in another process
    other.claim("from_the_copy.png")
    real_open = os.open

    def no_reopen(path, *args, **kwargs):
        assert Path(path).name != JOURNAL, "the journal's name was opened again"
        return real_open(path, *args, **kwargs)

    monkeypatch.setattr(os, "open", no_reopen)
    j.claim("a.txt", "b.txt")
    monkeypatch.undo()
    assert j.entries() == ["from_the_copy.png", "a.txt", "b.txt"]
    j.close()


@pytest.mark.parametrize("planted", ["symlink", "hardlink", "new_file", "none"])
def test_an_adopted_journal_is_appended_to_only_while_it_is_the_runs(tmp_path, planted):
    """A helper process journals by name (``adopted``: it did not create the journal). A link
    or another file planted under that name: the claim fails, the file outside the output is
    untouched and nothing is created (opened without following a link, never with O_CREAT,
    written only while its device and inode are the journal the run created)."""
    from flexlift.plumbing.marker import adopted, claim

    outside = tmp_path / "outside.txt"
    outside.write_text("the user's\n")
    out = tmp_path / "out"
    out.mkdir()
    run = Journal(out).start()  # the run's own (held open: its inode cannot be reused)
    try:
        if planted != "none":
            os.unlink(out / JOURNAL)
        if planted == "symlink":
            os.symlink(outside, out / JOURNAL)
        elif planted == "hardlink":
            os.link(outside, out / JOURNAL)
        elif planted == "new_file":
            (out / JOURNAL).write_text('"a.txt"\n')
        with adopted([(str(out), list(run.ident))]):
            if planted == "none":  # the journal itself: appended to
                claim(out / "x.txt")
                assert (out / JOURNAL).read_text() == '"x.txt"\n'
            else:
                with pytest.raises(OSError):
                    claim(out / "x.txt")
    finally:
        run.close()
    assert outside.read_text() == "the user's\n"
    if planted == "new_file":
        assert (out / JOURNAL).read_text() == '"a.txt"\n'
