"""Named tuples of arrays passed by reference inside compiled code.

The compiled loop keeps its data in named tuples of NumPy arrays (plain Python data, shared
with the rest of flexlift). Passing such a tuple from one compiled function to another costs a
reference count per array it holds, about 3 ns each: with ~40 arrays a tuple and ~30 calls a
step that was 5 µs of a 6 µs step (measured). :func:`as_struct` wraps a named tuple once, at
the entry of the compiled loop, into a mutable struct (numba ``StructRef``) holding the *same*
arrays (no copy; writes go to the tuple's arrays); a struct is passed as one pointer.

The struct's arrays are *borrowed* (:func:`_borrow`: the tuple's data, shape and strides with
no owner of their own). Every use of an owned array read out of a struct takes and releases a
reference, an atomic operation each, which numba prunes only within straight-line code: in
the loop's step (loops and branches over a hundred or so arrays) they were a third of the
step's time (tanker: 2.4 µs a step owned, 1.7 µs borrowed, the same numbers to the last bit).
The tuple passed to the compiled call keeps the arrays alive for as long as the struct lives;
a struct's array must never be returned to Python or kept past the call.

A struct itself is counted like an owned array: passing one to a compiled function that is not
inlined, or reading one out of another (``plant.bags``), takes and releases a reference, an
atomic operation each, on every step (measured with ``perf`` on a sweep's tanker cases: 12 % of
the loop's time inside numba's ``NRT_incref``/``NRT_decref``). So a named tuple inside the tuple
becomes a :class:`View` inside the struct: the same struct, with no reference of its own (its
data model holds nothing numba counts), kept alive by a hidden owning field beside it
(``owns_bags``), which the outer struct frees with itself; and :func:`view` gives the same of a
whole struct, for code that holds the struct itself meanwhile (the loop's entry passes the
owning tuple of structs down and works on views of them). A view must never outlive the
struct it was taken from: the function that takes the owning structs as an argument must stay
a real call (numba frees a local or an inlined argument after its last use, and the views
would read reused memory: tests/test_struct.py checks the kernel's), and a view is never kept
in a container (a typed List) or returned (numba refuses to return one to Python).

Only numba's public extension APIs are used: ``structref.register`` and
``structref.define_attributes`` for the types and their attributes (with numba's own
``StructRefModel``, or a subclass of it that reports no counted member for the view),
``structref.new`` to allocate one (as numba's own ``define_constructor`` does; it frees the
struct), and ``numba.extending.intrinsic`` for :func:`_borrow` (the array's data model as
numba's own ``carray`` fills it) and :func:`view`. tests/test_struct.py checks the sharing and
that no reference and no struct is leaked.
"""

from __future__ import annotations

from types import SimpleNamespace

import numba
from numba.core import cgutils, types
from numba.core.datamodel import default_manager, models
from numba.experimental import structref
from numba.extending import intrinsic, overload

__all__ = ["Struct", "View", "as_struct", "view"]


@structref.register
class Struct(types.StructRef):
    """A struct with the fields of a named tuple (one numba type per set of fields)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class View(types.StructRef):
    """A :class:`Struct` without a reference of its own (module docstring): the same fields and
    payload, read and written the same way; numba counts nothing of it."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


class _ViewModel(models.StructRefModel):
    """A struct's data model (its payload's meminfo pointer) with no member numba counts:
    taking or releasing a view emits nothing."""

    def traverse(self, builder):
        return []

    def inner_models(self):
        return []


default_manager.register(View, _ViewModel)
structref.define_attributes(View)


def view(st):
    """``view(st)`` in compiled code: a :class:`View` of the struct ``st``, valid while ``st``
    is held by its caller (e.g. an argument of the function taking the view).
    ``NUMBA_DISABLE_JIT``: ``st`` itself."""
    if not numba.config.DISABLE_JIT:
        raise TypeError("view is for compiled code only")
    return st


@intrinsic
def _view(typingctx, st):
    def codegen(context, builder, sig, args):
        return args[0]  # the same meminfo pointer, no reference taken

    return View(list(st.field_dict.items()))(st), codegen


@overload(view)
def _view_of(st):
    if isinstance(st, Struct):
        return lambda st: _view(st)
    return None


def as_struct(tup):
    """``as_struct(t)`` in compiled code: a :class:`Struct` with the fields of the named
    tuple ``t``, referring to the same arrays, borrowed (no reference of their own: module
    docstring); a named tuple inside ``t`` becomes a struct inside it
    (``plant.bags.capacity``).

    ``t`` must be an argument the compiled function was called with from Python (Python
    then keeps its arrays alive for the whole call), never a tuple built inside compiled code
    (its arrays may be freed while the struct still points at them), and no array read out
    of the struct may be returned to Python (it would point into memory it does not keep)."""
    if not numba.config.DISABLE_JIT:
        raise TypeError("as_struct is for compiled code only")
    # NUMBA_DISABLE_JIT: the compiled code runs as Python; a namespace of the same fields,
    # the same arrays
    return SimpleNamespace(**{name: as_struct(value) if _is_named_tuple(value) else value
                              for name, value in zip(tup._fields, tup)})


def _is_named_tuple(value) -> bool:
    return isinstance(value, tuple) and hasattr(value, "_fields")


def _struct_type(tup):
    """The :class:`Struct` type of a named tuple type: a named tuple in it becomes a
    :class:`View` field of its struct and a hidden field ``owns_<name>`` owning that struct."""
    fields = []
    for name, typ in zip(tup.fields, tup.types):
        if isinstance(typ, types.BaseNamedTuple):
            inner = _struct_type(typ)
            fields += [(name, View(list(inner.field_dict.items()))), (f"owns_{name}", inner)]
        else:
            fields.append((name, typ))
    return Struct(fields)


@overload(as_struct)
def _as_struct(tup):
    if not isinstance(tup, types.BaseNamedTuple):
        return None
    st_type = _struct_type(tup)
    def line(name, typ):
        if isinstance(typ, types.BaseNamedTuple):  # owned by a hidden field, read as a view
            return (f"    st.owns_{name} = as_struct(tup.{name})\n"
                    f"    st.{name} = view(st.owns_{name})\n")
        if isinstance(typ, types.Array):
            return f"    st.{name} = borrow(tup.{name})\n"
        return f"    st.{name} = tup.{name}\n"

    lines = "".join(line(name, typ) for name, typ in zip(tup.fields, tup.types))
    source = f"def impl(tup):\n    st = new(st_type)\n{lines}    return st\n"
    glbs = {"new": structref.new, "st_type": st_type, "as_struct": as_struct, "borrow": _borrow,
            "view": view}
    exec(source, glbs)  # a constructor for these fields, as structref.define_constructor does
    return glbs["impl"]


@intrinsic
def _borrow(typingctx, arr):
    """The array ``arr`` without its owner: the same data, shape and strides, no meminfo (as
    ``numba.carray`` makes). Taking and releasing a reference to it costs nothing, where
    each reference to an owned array is an atomic operation (measured: a third of a loop
    step). Valid only while ``arr`` is kept alive by someone else, as the named tuple given
    to :func:`as_struct` keeps its arrays for the compiled call; never return one to
    Python."""
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, sig, args):
        src = context.make_array(arr)(context, builder, args[0])
        out = context.make_array(arr)(context, builder)
        out.meminfo = cgutils.get_null_value(out.meminfo.type)
        out.parent = cgutils.get_null_value(out.parent.type)
        out.nitems, out.itemsize, out.data = src.nitems, src.itemsize, src.data
        out.shape, out.strides = src.shape, src.strides
        return out._getvalue()

    return arr(arr), codegen
