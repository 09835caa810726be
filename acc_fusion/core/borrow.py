r"""Arrays without a reference count, for the inner loops of the compiled kernels.

Every numba array carries a pointer to its *meminfo*, the reference count of the memory it
views.  Each time a kernel passes an array to a helper or takes a view of it (``x[k]``), numba
increments that count and decrements it afterwards, two atomic operations, and its reference
count pruning removes the pair only when both fall in one basic block, which a helper with a
loop or a branch prevents.  In a kernel that calls a few helpers on a few arrays per pair,
these atomics cost more than the arithmetic: the association's distance of two tracks, four
arrays passed, took 45 ns instead of 8 (a throwaway probe on 10⁵ track pairs, 2026-11-27).

:func:`borrow` returns the same array, same data, shape and strides, with a null meminfo:
numba skips the count of a null meminfo, and so do the views taken of it.  It is safe for as
long as something else holds the memory: a kernel's *arguments* (the caller holds them for
the whole call), or an array the kernel allocated itself and names in a :func:`keep_alive`
after its last use of the borrowed view (numba frees a variable after its last use, which
would otherwise be the ``borrow`` call).  A borrowed array must not leave the kernel: not
returned, not stored in anything that outlives the call.
"""

from __future__ import annotations

from numba.core import cgutils, types
from numba.extending import intrinsic


def _borrowed(context, builder, aryty, value):  # pragma: no cover - compiled
    """The array struct ``value`` of type ``aryty`` with a null meminfo."""
    src = context.make_array(aryty)(context, builder, value=value)
    out = context.make_array(aryty)(context, builder)
    for name in ("parent", "nitems", "itemsize", "data", "shape", "strides"):
        setattr(out, name, getattr(src, name))
    out.meminfo = cgutils.get_null_value(out.meminfo.type)
    return out._getvalue()


@intrinsic
def borrow(typingctx, arrays):  # pragma: no cover - compiled
    """``arrays`` (an array, or a tuple of arrays) without their reference counts (module
    docstring): only inside a kernel."""
    if isinstance(arrays, types.Array):

        def one(context, builder, signature, args):
            return _borrowed(context, builder, arrays, args[0])

        return arrays(arrays), one
    if not isinstance(arrays, types.BaseTuple) or not all(
        isinstance(t, types.Array) for t in arrays
    ):
        return None

    def each(context, builder, signature, args):
        values = [
            _borrowed(context, builder, t, builder.extract_value(args[0], i))
            for i, t in enumerate(arrays)
        ]
        return context.make_tuple(builder, signature.return_type, values)

    return arrays(arrays), each


@intrinsic
def keep_alive(typingctx, owners):  # pragma: no cover - compiled
    """Use ``owners`` (an array, or a tuple of them) here, so that numba frees them no
    earlier: the arrays a kernel allocated and :func:`borrow`\\ ed (module docstring).  Does
    nothing."""
    if not isinstance(owners, (types.Array, types.BaseTuple)):
        return None

    def codegen(context, builder, signature, args):
        return context.get_dummy_value()

    return types.none(owners), codegen
