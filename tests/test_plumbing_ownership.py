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
