"""Real ``.fis`` files mutated (hypothesis): parsed with every number finite, or one InputError.

The corpus of tests/data/fis (MATLAB's shipped examples, Octave's, fuzzylite's) is mutated by
truncation, bit flips, numbers replaced by huge, tiny, non-finite or deeply nested arithmetic
ones, and such text inserted anywhere. Whatever comes out, reading it either gives a system
whose every range end, parameter and weight is finite and that evaluates to finite outputs
at the centre and the corners of its input ranges, or raises one short InputError line:
never an OverflowError, a RecursionError, a NaN. Derandomized (the same examples on every run)
and sized to a few seconds.
"""

import re
import signal
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from flexlift.errors import InputError
from flexlift.fuzzy.fis import read_fis

CORPUS = sorted((Path(__file__).parent / "data" / "fis").rglob("*.fis"))


def _readable(path: Path) -> bool:
    try:
        read_fis(path)
    except InputError:  # another tool's custom operator or set: mutating it proves little
        return False
    return True


#: the corpus files flexlift reads as they are: each mutant starts from a valid system
TEXTS = [p.read_bytes() for p in CORPUS if _readable(p)]
#: what a hostile file writes for a number
NASTY = ["inf", "-inf", "nan", "NaN", "1e999", "-1e999", "1e308", "-1.7e308", "1e-320",
         "1e-200", "1e100", "1e101", "4.5", "-0", "0", "1e15", "9^9^9^9", "pi^999", "(-8)^0.5",
         "1/0", "0/0", "2^-1074", "-" * 3000 + "1", "+".join(["1"] * 3000),
         "(" * 200 + "1" + ")" * 200, "1" * 400, "1e", "--1", "\u00e9", "\x00", "\xff"]
#: a number in a list, a range, a rule or after "=" (not the 1 of [Input1])
_NUMBER = re.compile(rb"(?<=[\[\s(=,])-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?=[\s\]),:]|$)", re.M)
#: the set indices and weights of a rule line ("1 2, 3 (1) : 1")
_RULE_NUMBER = re.compile(rb"(?<=[\s(,])-?\d+(?:\.\d+)?(?=[\s,)])")


@st.composite
def mutated(draw) -> bytes:
    data = bytearray(draw(st.sampled_from(TEXTS)))
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(("truncate", "flip", "number", "number", "rule", "insert")))
        if op == "truncate" and data:  # mostly in the rules and the last sets
            del data[draw(st.integers(len(data) // 2, len(data) - 1)):]
        elif op == "flip" and data:
            i = draw(st.integers(0, len(data) - 1))
            data[i] ^= 1 << draw(st.integers(0, 7))
        elif op == "number":
            found = list(_NUMBER.finditer(bytes(data)))
            if found:
                m = draw(st.sampled_from(found))
                data[m.start():m.end()] = draw(st.sampled_from(NASTY)).encode("utf-8", "ignore") \
                    if draw(st.booleans()) else draw(st.sampled_from(NASTY)).encode("latin-1")
        elif op == "rule":
            start = bytes(data).find(b"[Rules]")
            found = list(_RULE_NUMBER.finditer(bytes(data), max(start, 0))) if start >= 0 else []
            if found:
                m = draw(st.sampled_from(found))
                data[m.start():m.end()] = draw(st.sampled_from(NASTY)).encode("utf-8")
        elif op == "insert":
            i = draw(st.integers(0, len(data)))
            data[i:i] = draw(st.sampled_from(NASTY)).encode("utf-8")
    return bytes(data)


def _numbers(fis) -> list[float]:
    out = []
    for v in (*fis.inputs, *fis.outputs):
        out += list(v.range)
        for m in v.mfs:
            out += list(m.params)
    return out + [r.weight for r in fis.rules]


@pytest.fixture(autouse=True, scope="module")
def hang_guard():
    def hung(signum, frame):
        pytest.fail("the mutated .fis files took more than 300 s")

    old = signal.signal(signal.SIGALRM, hung)
    signal.alarm(300)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


def test_the_corpus_is_there():
    assert len(CORPUS) >= 30 and len(TEXTS) >= 25


@settings(max_examples=400, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(mutated())
def test_a_mutated_fis_is_parsed_finite_or_refused_in_one_line(data):
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "mutant.fis"
        path.write_bytes(data)
        try:
            fis = read_fis(path)
        except InputError as exc:
            msg = str(exc)
            assert "\n" not in msg and "\r" not in msg and len(msg) < 600, msg
            return
    assert all(np.isfinite(_numbers(fis)))
    lo = np.array([v.range[0] for v in fis.inputs])
    hi = np.array([v.range[1] for v in fis.inputs])
    with np.errstate(all="ignore"):  # a steep sigmoid's exp may overflow to a finite 0 or 1
        u = np.asarray(fis(np.stack([lo, hi, (lo + hi) / 2])))
    assert np.all(np.isfinite(u)), u
