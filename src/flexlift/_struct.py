"""Named tuples of arrays passed by reference inside compiled code.

The compiled loop keeps its data in named tuples of NumPy arrays (plain Python data, shared
with the rest of flexlift). Passing such a tuple from one compiled function to another costs a
reference count per array it holds, about 3 ns each: with ~40 arrays a tuple and ~30 calls a
step that was 5 µs of a 6 µs step (measured). :func:`as_struct` wraps a named tuple once, at
the entry of the compiled loop, into a mutable struct (numba ``StructRef``) holding the *same*
arrays (no copy; writes go to the tuple's arrays); a struct is passed as one pointer.
"""

from __future__ import annotations

from numba.core import cgutils, types
from numba.experimental import structref
from numba.experimental.jitclass.base import imp_dtor
from numba.extending import intrinsic

__all__ = ["Struct", "as_struct"]


@structref.register
class Struct(types.StructRef):
    """A struct with the fields of a named tuple (one numba type per set of fields)."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(typ)) for name, typ in fields)


@intrinsic
def as_struct(typingctx, tup):
    """``as_struct(t)`` in compiled code: a :class:`Struct` with the fields of the named
    tuple ``t``, referring to the same arrays (their reference counts taken once)."""
    if not isinstance(tup, types.BaseNamedTuple):
        return None
    st_type = Struct(list(zip(tup.fields, tup.types)))

    def codegen(context, builder, sig, args):
        [val] = args
        model = context.data_model_manager[st_type.get_data_type()]
        alloc_type = model.get_value_type()
        size = context.get_abi_sizeof(alloc_type)
        meminfo = context.nrt.meminfo_alloc_dtor(
            builder, context.get_constant(types.uintp, size),
            imp_dtor(context, builder.module, st_type))
        ptr = builder.bitcast(context.nrt.meminfo_data(builder, meminfo), alloc_type.as_pointer())
        builder.store(cgutils.get_null_value(alloc_type), ptr)
        inst = context.make_helper(builder, st_type)
        inst.meminfo = meminfo
        data = cgutils.create_struct_proxy(st_type.get_data_type())(context, builder, ref=ptr)
        for i, (name, ty) in enumerate(zip(tup.fields, tup.types)):
            value = builder.extract_value(val, i)
            context.nrt.incref(builder, ty, value)
            setattr(data, name, value)
        return inst._getvalue()

    return st_type(tup), codegen
