"""as_struct: a named tuple's arrays shared by reference in compiled code, none leaked."""

import sys
from typing import NamedTuple

import numba
import numpy as np
import pytest

from flexlift._struct import as_struct, view


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


@numba.njit
def _inner_sum(o):
    """Reads a struct inside a struct (a view) in a loop, and writes through it."""
    s = 0.0
    for i in range(o.pair.a.size):
        s += o.pair.a[i] * o.c[0] + o.pair.k
    o.pair.a[0] += 1.0
    return s


@numba.njit
def _on_views(owned, n):
    v = view(owned)  # held by this function's caller meanwhile
    s = 0.0
    for _ in range(n):
        s += _inner_sum(v)  # a view passed to a function that is not inlined
    return s


@numba.njit
def _entry(t, n):
    return _on_views(as_struct(t), n)


@pytest.mark.skipif(numba.config.DISABLE_JIT, reason="NUMBA_DISABLE_JIT: nothing is allocated")
def test_views_read_and_write_the_same_struct_and_no_struct_is_leaked():
    """A struct inside a struct is a view kept alive by its hidden owner (``owns_pair``),
    and view() of a held struct is the same struct: the reads and writes go to the tuple's
    arrays, and every struct allocated is freed (numba's allocation counts)."""
    from numba.core.runtime import _nrt_python, rtsys

    t = Outer(Pair(np.ones(3), np.zeros(2), 2), np.full(1, 3.0))
    # calls with a[0] = 1 .. 5, each sum 3 a0 + 3 + 3 (the other two) + 3 k
    assert _entry(t, 5) == sum(3.0 * a0 + 3.0 + 3.0 + 6.0 for a0 in range(1, 6))
    assert t.pair.a.tolist() == [6.0, 1.0, 1.0]
    was_on = _nrt_python.memsys_stats_enabled()
    _nrt_python.memsys_enable_stats()  # as NUMBA_NRT_STATS=1 would
    try:
        before = rtsys.get_allocation_stats()
        refs = sys.getrefcount(t.pair.a), sys.getrefcount(t.c)
        for _ in range(200):
            _entry(t, 2)
        after = rtsys.get_allocation_stats()
    finally:
        if not was_on:
            _nrt_python.memsys_disable_stats()
    made = after.mi_alloc - before.mi_alloc
    assert made > 0 and after.mi_free - before.mi_free == made  # the structs, all freed
    assert (sys.getrefcount(t.pair.a), sys.getrefcount(t.c)) == refs


def test_the_fields_of_a_struct_inside_are_a_view_and_its_owner():
    from flexlift._struct import View, _struct_type

    st = _struct_type(numba.typeof(Outer(Pair(np.ones(3), np.ones(2), 2), np.ones(1))))
    assert isinstance(st.field_dict["pair"], View)
    assert st.field_dict["owns_pair"].field_dict == st.field_dict["pair"].field_dict


def test_the_loops_entry_points_that_hold_the_structs_are_real_calls():
    """The kernel's views are valid only while a caller holds their structs: the functions
    taking the owning tuple (``_advance``, ``_initial_equilibrium``, ``_final_row``) must stay
    calls. Inlined, the tuple would be freed after its last use, the views' memory reused
    (a reviewer's experiment: the step read another struct's numbers)."""
    from flexlift.ascent import kernel

    for fn in (kernel._advance, kernel._initial_equilibrium, kernel._final_row):
        assert getattr(fn, "targetoptions", {"inline": "never"}).get("inline", "never") == "never"
