"""Every file flexlift reads is read within bounds (issue 21), and a hostile ``.fis`` file is one
line, never an internal error.

The reader (:mod:`flexlift.plumbing.reading`) takes a regular UTF-8 file of at most 1 MB, opened
without blocking, reading at most 1 MB + 1 bytes whatever the file's size says: a FIFO, a
device, a symbolic link to one, a 3 GB sparse file, a folder, a link that loops, a name too
long, a Latin-1 or UTF-16 file are each one InputError line naming the file. Checked for a
``.fis`` through the API, ``flexlift fuzzy --fis X``, a scenario's
``control.supervisor.fis_file: X`` and a sweep SPEC's ``set:``; and for the numbers inside a
``.fis`` (non-finite and huge counts and indices, deep arithmetic, an overflowing Sugeno
coefficient, a set that is NaN on its range). Every test carries a hang guard (SIGALRM): a
regression that blocks fails instead of hanging.
"""

import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml

from flexlift.cli import main
from flexlift.errors import InputError
from flexlift.fuzzy.fis import read_fis, to_fis_text
from flexlift.fuzzy.rulebase import supervisor_fis
from flexlift.plumbing import reading

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="FIFOs, devices, sparse files, /proc")

#: a hang guard only [s]: each test takes well under a second when nothing blocks
HANG_S = 60
LIMIT = reading.MAX_BYTES
GOOD = to_fis_text(supervisor_fis())


#: address space a test may add [bytes]: a regression that reads /dev/zero whole fails
#: with MemoryError instead of taking the machine's memory
MEMORY = 2 << 30


def _address_space() -> int:
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmSize:"))


@pytest.fixture(autouse=True)
def guards():
    """A hang guard (SIGALRM) and a memory guard (RLIMIT_AS) around every test."""
    def hung(signum, frame):  # pytest's Failed is no OSError: no `except OSError` swallows it
        pytest.fail(f"still running after {HANG_S} s: reading blocked")

    old = signal.signal(signal.SIGALRM, hung)
    signal.alarm(HANG_S)
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    cap = _address_space() + MEMORY
    if hard != resource.RLIM_INFINITY:
        cap = min(cap, hard)
    resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


@pytest.fixture
def bytes_read(monkeypatch):
    """The bytes read by os.read (the reader's only way in) during the test."""
    seen = {"n": 0}
    real = os.read

    def counting(fd, n):
        data = real(fd, n)
        seen["n"] += len(data)
        return data

    monkeypatch.setattr(os, "read", counting)
    return seen


# --------------------------------------------------------------------------- hostile files
def _fifo(d: Path) -> Path:
    p = d / "pipe.fis"
    os.mkfifo(p)  # nobody ever writes: opening it to read blocks unless opened non-blocking
    return p


def _zero_link(d: Path) -> Path:
    p = d / "zero.fis"
    p.symlink_to("/dev/zero")
    return p


def _sparse(d: Path) -> Path:
    p = d / "huge.fis"
    p.write_text(GOOD)
    os.truncate(p, 3 * 2**30)  # 3 GB, nearly all of it a hole: no disk used
    return p


def _folder(d: Path) -> Path:
    p = d / "folder.fis"
    p.mkdir()
    return p


def _loop(d: Path) -> Path:
    (d / "a.fis").symlink_to(d / "b.fis")
    (d / "b.fis").symlink_to(d / "a.fis")
    return d / "a.fis"


def _latin1(d: Path) -> Path:
    p = d / "latin1.fis"
    p.write_bytes(GOOD.replace("Name='e'", "Name='Düse'").encode("latin-1"))
    return p


def _utf16(d: Path) -> Path:
    p = d / "utf16.fis"
    p.write_bytes(GOOD.encode("utf-16"))
    return p


def _missing(d: Path) -> Path:
    return d / "nope.fis"


def _long_name(d: Path) -> Path:
    return d / ("x" * 300 + ".fis")  # one name longer than any file system's 255


HOSTILE = {
    "fifo": (_fifo, ["a FIFO (named pipe), not a regular file"]),
    "symlink to /dev/zero": (_zero_link, ["a character device, not a regular file"]),
    "3 GB sparse file": (_sparse, ["larger than 1,000,000 bytes (1 MB)", "a few kB"]),
    "folder": (_folder, ["a folder, not a .fis file"]),
    "symlink loop": (_loop, ["a symbolic link that loops"]),
    "latin-1": (_latin1, ["not UTF-8 text: byte 0xfc at line", "iconv -f WINDOWS-1252 -t UTF-8",
                          'Encoding="windows-1252"']),
    "utf-16": (_utf16, ["UTF-16 text", "iconv -f UTF-16 -t UTF-8"]),
    "missing": (_missing, ["no such file", "MATLAB .fis file"]),
    "name too long": (_long_name, ["File name too long", "characters, more than the system "
                                   "allows"]),
}
#: the needle when flexlift's loop looks at the file before reading it (os.stat, one line)
STAT = {"symlink loop": "Too many levels of symbolic links", "missing": "No such file",
        "name too long": "File name too long"}


def _one_line(capsys, *needles) -> str:
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in cap.err and "internal error" not in cap.err, \
        cap.err
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize("name", HOSTILE)
def test_reading_a_hostile_fis_is_refused_having_read_at_most_1_MB(name, tmp_path, bytes_read):
    make, needles = HOSTILE[name]
    path = make(tmp_path)
    with pytest.raises(InputError) as e:
        read_fis(path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(str(path)[:40]), msg
    for n in needles:
        assert n in msg, msg
    assert bytes_read["n"] <= LIMIT + 1


def test_dev_zero_itself_and_the_sparse_file_read_nothing_or_1_MB_plus_one(tmp_path, bytes_read):
    with pytest.raises(InputError, match="a character device"):
        read_fis("/dev/zero")
    assert bytes_read["n"] == 0  # refused from its file type, before reading
    with pytest.raises(InputError, match="larger than"):
        read_fis(_sparse(tmp_path))
    assert bytes_read["n"] == LIMIT + 1  # not its 3 GB: one byte past the limit tells


def test_a_file_of_exactly_1_MB_is_read(tmp_path):
    p = tmp_path / "padded.fis"
    text = GOOD + "%" * (LIMIT - len(GOOD.encode()) - 1) + "\n"
    p.write_text(text)
    assert p.stat().st_size == LIMIT
    assert read_fis(p).n_inputs == 2


@pytest.mark.parametrize("name", HOSTILE)
def test_fuzzy_fis_option_is_one_line_and_exit_2(name, tmp_path, capsys):
    make, needles = HOSTILE[name]
    assert main(["fuzzy", "--fis", str(make(tmp_path)), "--eval", "0,0", "--json"]) == 2
    _one_line(capsys, "flexlift fuzzy: error:", *needles)


def _scenario(d: Path, fis_file: str) -> Path:
    p = d / "s.yaml"
    p.write_text(yaml.safe_dump({"name": "mine", "control": {"supervisor": {
        "fis_file": fis_file}}}))
    return p


@pytest.mark.parametrize("name", HOSTILE)
def test_a_scenarios_supervisor_file_is_one_line_and_exit_2(name, tmp_path, capsys):
    make, needles = HOSTILE[name]
    path = make(tmp_path)
    assert main(["fuzzy", str(_scenario(tmp_path, path.name)), "--eval", "0,0", "--json"]) == 2
    _one_line(capsys, "flexlift fuzzy: error:", path.name[:10],
              *([STAT[name]] if name in STAT else needles))


def _sweep_spec(d: Path, fis_name: str) -> Path:
    spec = d / "spec.yaml"
    spec.write_text(yaml.safe_dump({
        "base": "tanker", "control": ["coordinated"],
        "set": {"control.supervisor.fis_file": fis_name},
        "grid": {"seabed.breakout_time_s": [300]}}))
    return spec


#: files that would block or fill the memory of a sweep's worker processes, out of reach of
#: this process's guards: run in a process of their own
IN_WORKERS = ("fifo", "symlink to /dev/zero")


@pytest.mark.parametrize("name", [n for n in HOSTILE if n not in IN_WORKERS])
def test_a_sweep_specs_set_file_is_one_line_and_exit_2_before_any_case(name, tmp_path, capsys):
    make, needles = HOSTILE[name]
    spec = _sweep_spec(tmp_path, make(tmp_path).name)
    out = tmp_path / "o"
    assert main(["sweep", str(spec), "--out", str(out)]) == 2
    _one_line(capsys, "flexlift sweep: error:", "control.supervisor.fis_file", *needles)
    assert not out.exists()


def _limited():  # in the child: at most 3 GB of address space (its workers inherit it)
    resource.setrlimit(resource.RLIMIT_AS, (3 << 30, 3 << 30))


@pytest.mark.parametrize("name", IN_WORKERS)
def test_a_sweep_never_hands_a_fifo_or_device_to_its_workers(name, tmp_path):
    make, needles = HOSTILE[name]
    spec = _sweep_spec(tmp_path, make(tmp_path).name)
    out = tmp_path / "o"
    signal.alarm(0)  # the subprocess's own timeout guards this test
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(Path(__file__).resolve().parents[1] / "src"), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, "-m", "flexlift", "sweep", str(spec), "--out",
                             str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=env, start_new_session=True, preexec_fn=_limited)
    try:
        _, err = proc.communicate(timeout=HANG_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # the sweep and its workers, all of them ours
        proc.communicate()
        pytest.fail(f"flexlift sweep still running after {HANG_S} s with {name} under set:")
    lines = err.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "Traceback" not in err, err
    for n in ("control.supervisor.fis_file", *needles):
        assert n in lines[0], lines[0]
    assert not out.exists()


def test_the_copy_into_an_output_folder_and_the_checksum_are_bounded(tmp_path, bytes_read,
                                                                      tanker):
    from flexlift.output.controllers import copy_controller_files
    from flexlift.scenario.schema import file_sha256

    for make in (_fifo, _zero_link, _sparse):
        (tmp_path / make.__name__).mkdir()
        path = make(tmp_path / make.__name__)
        before = bytes_read["n"]
        assert file_sha256(path)  # the path's hash: the file is refused when read for use
        scenario = tanker.with_changes(**{"control.supervisor.fis_file": str(path)})
        with pytest.raises(InputError, match=path.name):
            copy_controller_files(scenario, tmp_path / "out")
        assert bytes_read["n"] - before <= 2 * (LIMIT + 1)


# --------------------------------------------------------------------------- paths
def test_a_relative_fis_that_loops_in_a_scenario_is_one_line(tmp_path, capsys):
    from flexlift import load_scenario

    _loop(tmp_path)
    s = load_scenario(_scenario(tmp_path, "a.fis"))  # Path.resolve raised RuntimeError here
    assert s.control.supervisor.fis_file == str(tmp_path.resolve() / "a.fis")
    assert main(["fuzzy", str(_scenario(tmp_path, "a.fis")), "--eval", "0,0"]) == 2
    _one_line(capsys, "a.fis", "Too many levels of symbolic links")
    assert main(["fuzzy", "--fis", str(tmp_path / "a.fis"), "--eval", "0,0"]) == 2
    _one_line(capsys, "a.fis: a symbolic link that loops")


def test_a_link_named_fis_keeps_its_name_in_a_scenario(tmp_path):
    from flexlift import load_scenario

    _zero_link(tmp_path)  # resolved, it would be '/dev/zero': "not a .fis file"
    s = load_scenario(_scenario(tmp_path, "zero.fis"))
    assert s.control.supervisor.fis_file == str(tmp_path.resolve() / "zero.fis")


@pytest.mark.parametrize("base, needles", [
    ("b" * 5000, ["base:", "File name too long", "5,000 characters"]),
    ("b" * 300 + ".yaml", ["base:", "File name too long"]),
    ("bad\x00name.yaml", ["base:", "not a valid path"]),
])
def test_a_sweep_base_that_cannot_be_a_file_is_one_line(base, needles, tmp_path, capsys):
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({"base": base, "grid": {"seabed.breakout_time_s": [300]}}))
    assert main(["sweep", str(spec), "--out", str(tmp_path / "o")]) == 2
    _one_line(capsys, "flexlift sweep: error:", *needles)


def test_a_spec_file_that_is_a_fifo_or_device_is_one_line(tmp_path, capsys):
    fifo = tmp_path / "spec.yaml"
    os.mkfifo(fifo)
    assert main(["sweep", str(fifo), "--out", str(tmp_path / "o")]) == 2
    _one_line(capsys, "a FIFO (named pipe)", "a SPEC is read only from a regular YAML file")
    assert main(["sweep", "/dev/zero", "--out", str(tmp_path / "o")]) == 2
    _one_line(capsys, "/dev/zero: a character device")
    assert main(["sweep", str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "o")]) == 2
    _one_line(capsys, "no such file; give the path of a sweep SPEC")


# --------------------------------------------------------------------------- numbers
SUGENO = """[System]
Name='lin'
Type='sugeno'
NumInputs=2
NumOutputs=1
NumRules=2
AndMethod='prod'
OrMethod='probor'
ImpMethod='prod'
AggMethod='sum'
DefuzzMethod='wtaver'

[Input1]
Name='e'
Range=[-1 1]
NumMFs=2
MF1='n':'trimf',[-2 -1 1]
MF2='p':'trimf',[-1 1 2]

[Input2]
Name='edot'
Range=[-1 1]
NumMFs=1
MF1='z':'trimf',[-2 0 2]

[Output1]
Name='u'
Range=[-1 1]
NumMFs=2
MF1='a':'linear',[{coef} 0 0]
MF2='b':'constant',[0.5]

[Rules]
1 1, 1 (1) : 1
2 1, 2 (1) : 1
"""
DEEP_SUM = "+".join(["1"] * 3000)


def _edit(old: str, new: str) -> str:
    assert old in GOOD
    return GOOD.replace(old, new, 1)


ZE = "[0.14155363338133647 0]"  # the parameters of set ZE of the first input
RULE = GOOD.split("[Rules]\n")[1].splitlines()[0]
BAD_NUMBERS = {
    "NumInputs=inf": (_edit("NumInputs=2", "NumInputs=inf"), ["NumInputs=inf", "whole number"]),
    "NumInputs=nan": (_edit("NumInputs=2", "NumInputs=nan"), ["NumInputs=nan", "whole number"]),
    "NumInputs=1e999": (_edit("NumInputs=2", "NumInputs=1e999"), ["whole number 0..100"]),
    "NumOutputs=inf": (_edit("NumOutputs=1", "NumOutputs=inf"), ["NumOutputs=inf"]),
    "NumRules=1e999": (_edit("NumRules=", "NumRules=1e999\n%"), ["NumRules=1e999"]),
    "NumMFs=inf": (_edit("NumMFs=", "NumMFs=inf\n%"), ["NumMFs=inf", "0..1,000"]),
    "NumMFs=1e15": (_edit("NumMFs=", "NumMFs=1e15\n%"), ["NumMFs=1e15", "0..1,000"]),
    "rule index 1e999": (_edit(RULE, "1e999" + RULE[1:]), ["1e999 is not finite"]),
    "rule index nan": (_edit(RULE, "nan" + RULE[1:]), ["rules are written"]),
    "rule weight inf": (_edit(RULE, "7 1, 4 (inf) : 1"), ["inf is not finite"]),
    "3,000-term sum in a range": (_edit("Range=[-1 1]", f"Range=[-1 {DEEP_SUM}]"),
                                  ["arithmetic of 5,999 characters", "at most 100"]),
    "3,000 minus signs in a parameter": (_edit(ZE, ZE.replace(" 0]", " " + "-" * 3000 + "0]")),
                                         ["arithmetic of 3,001 characters"]),
    "a range of 1e308": (_edit("Range=[-1 1]", "Range=[-1e308 1e308]"), ["beyond ±1e+100"]),
    "an overflowing power": (_edit("Range=[-1 1]", "Range=[-1 9^9^9^9]"), ["9^9^9^9 overflows"]),
    "a complex power": (_edit("Range=[-1 1]", "Range=[(-8)^0.5 1]"), ["not a real number"]),
    "a tiny sigma": (_edit(ZE, "[1e-200 0]"), ["'ZE'", "a set finite over the range",
                                               "it is nan at 0"]),
    "a Sugeno coefficient of 1e308": (SUGENO.format(coef="1e308"), ["1e308 is beyond ±1e+100"]),
}


def _fis_file(d: Path, text: str) -> Path:
    p = d / "bad.fis"
    p.write_text(text)
    return p


@pytest.mark.parametrize("name", BAD_NUMBERS)
def test_bad_numbers_in_a_fis_are_one_line(name, tmp_path):
    text, needles = BAD_NUMBERS[name]
    with pytest.raises(InputError) as e:
        read_fis(_fis_file(tmp_path, text))
    msg = str(e.value)
    assert msg.startswith("bad.fis") and "\n" not in msg and len(msg) < 400, msg
    for n in needles:
        assert n in msg, msg


@pytest.mark.parametrize("name", BAD_NUMBERS)
def test_bad_numbers_through_the_cli_and_a_scenario_are_exit_2(name, tmp_path, capsys):
    text, needles = BAD_NUMBERS[name]
    path = _fis_file(tmp_path, text)
    assert main(["fuzzy", "--fis", str(path), "--eval", "0,0", "--json"]) == 2
    _one_line(capsys, "flexlift fuzzy: error:", *needles)
    assert main(["fuzzy", str(_scenario(tmp_path, path.name)), "--eval", "0,0", "--json"]) == 2
    _one_line(capsys, "flexlift fuzzy: error:", *needles)


def test_a_sugeno_supervisor_within_the_limits_is_accepted_and_finite(tmp_path, capsys):
    import warnings

    path = _fis_file(tmp_path, SUGENO.format(coef="1e100"))
    fis = read_fis(path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        u = fis(np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 0.0], [1.0, 1.0]]))
    assert np.all(np.isfinite(u))


def test_a_hostile_name_never_makes_a_message_longer_than_a_line(tmp_path):
    from flexlift.errors import LINE_LIMIT

    text = GOOD.replace("Name='e'", "Name='" + "e" * 5000 + "'", 1).replace(
        RULE, "7.5" + RULE[1:], 1)
    with pytest.raises(InputError) as e:
        read_fis(_fis_file(tmp_path, text))
    msg = str(e.value)
    assert len(msg) <= LINE_LIMIT and "\n" not in msg, msg
    assert msg.startswith("bad.fis line") and msg.endswith("which flexlift does not support")
