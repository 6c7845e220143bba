"""as_struct: a named tuple's arrays shared by reference in compiled code, none leaked."""

import sys
from typing import NamedTuple

import numba
import numpy as np

from flexlift._struct import as_struct


class Pair(NamedTuple):
    a: np.ndarray
    b: np.ndarray
    k: int


@numba.njit
def _bump(t):
    s = as_struct(t)
    s.a[0] += s.k
    s.b[:] = s.a[0]
    return s.a.size + s.b.size


class Outer(NamedTuple):
    pair: Pair
    c: np.ndarray


@numba.njit
def _nested(t):
    s = as_struct(t)
    s.pair.a[1] = s.c[0] + s.pair.k
    return s.pair.a.size


def test_the_struct_refers_to_the_tuples_arrays():
    t = Pair(np.zeros(3), np.zeros(2), 5)
    assert _bump(t) == 5
    assert t.a[0] == 5.0 and np.all(t.b == 5.0)  # written through the struct, no copy


def test_no_reference_is_leaked():
    t = Pair(np.zeros(3), np.zeros(2), 1)
    _bump(t)
    before = sys.getrefcount(t.a), sys.getrefcount(t.b)
    for _ in range(100):
        _bump(t)
    assert (sys.getrefcount(t.a), sys.getrefcount(t.b)) == before


def test_a_named_tuple_inside_becomes_a_struct_inside():
    t = Outer(Pair(np.zeros(3), np.zeros(2), 2), np.full(1, 3.0))
    assert _nested(t) == 3 and t.pair.a[1] == 5.0
    before = sys.getrefcount(t.pair.a), sys.getrefcount(t.c)
    for _ in range(100):
        _nested(t)
    assert (sys.getrefcount(t.pair.a), sys.getrefcount(t.c)) == before
