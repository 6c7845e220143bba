"""Small dense products for the compiled loop, written as loops: on the few-by-few arrays of
a step, a BLAS call costs more in overhead (and a temporary array) than the arithmetic."""

from __future__ import annotations

from flexlift._jit import jit


@jit
def matvec(M, x, out):
    """out = M @ x (M (m, n), x (n,), out (m,)); returns out."""
    m, n = M.shape
    for i in range(m):
        s = 0.0
        for j in range(n):
            s += M[i, j] * x[j]
        out[i] = s
    return out


@jit
def matvec_add(M, x, out):
    """out += M @ x; returns out."""
    m, n = M.shape
    for i in range(m):
        s = 0.0
        for j in range(n):
            s += M[i, j] * x[j]
        out[i] += s
    return out


@jit
def dot(a, b):
    """a @ b for two vectors."""
    s = 0.0
    for i in range(a.size):
        s += a[i] * b[i]
    return s
