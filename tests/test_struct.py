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


@numba.njit
def _through_struct(t):
    s = as_struct(t)
    total = 0.0
    for i in range(s.a.size):
        s.a[i] += 1.0
        total += s.a[i]
    return total


def test_the_struct_borrows_strided_views_and_leaves_no_owner_behind():
    """The struct's arrays are borrowed (no reference of their own, the tuple keeps them):
    a strided view reads and writes the right elements, and after many calls the tuple's
    arrays are the only owners, as before any call."""
    base = np.arange(10.0)
    t = Pair(base[::3], np.zeros(2), 0)  # elements 0, 3, 6, 9
    before = sys.getrefcount(t.a), sys.getrefcount(base)
    for _ in range(50):
        _through_struct(t)
    assert _through_struct(t) == (0 + 3 + 6 + 9) + 4 * 51
    assert np.array_equal(base[[1, 2, 4]], [1.0, 2.0, 4.0])  # the others untouched
    assert (sys.getrefcount(t.a), sys.getrefcount(base)) == before
