"""Small dense products for the compiled loop, written as loops: on the few-by-few arrays of
a step, a BLAS call costs more in overhead (and a temporary array) than the arithmetic.

Each row's sum runs over its columns in order, one product added at a time, so a product is
the same to the last bit however the rows are grouped. Rows are taken four at a time (each
with its own sum): a row's sum is a chain of dependent additions, and four independent chains
keep the processor busy where one waits on each addition (the 5 x 44 product of the strips'
generalised force: 175 ns a row at a time).
"""

from __future__ import annotations

from flexlift._jit import inline_jit


@inline_jit
def _rows(matrix, x, out, add):
    """out = M @ x, or out += M @ x when ``add`` (``matrix`` M); rows four at a time, then one
    at a time."""
    m, n = matrix.shape
    i = 0
    while i + 4 <= m:
        s0, s1, s2, s3 = 0.0, 0.0, 0.0, 0.0
        for j in range(n):
            xj = x[j]
            s0 += matrix[i, j] * xj
            s1 += matrix[i + 1, j] * xj
            s2 += matrix[i + 2, j] * xj
            s3 += matrix[i + 3, j] * xj
        if add:
            out[i] += s0
            out[i + 1] += s1
            out[i + 2] += s2
            out[i + 3] += s3
        else:
            out[i], out[i + 1], out[i + 2], out[i + 3] = s0, s1, s2, s3
        i += 4
    while i < m:
        s = 0.0
        for j in range(n):
            s += matrix[i, j] * x[j]
        if add:
            out[i] += s
        else:
            out[i] = s
        i += 1
    return out


@inline_jit
def matvec(matrix, x, out):
    """out = M @ x (``matrix`` M (m, n), x (n,), out (m,)); returns out."""
    return _rows(matrix, x, out, False)


@inline_jit
def matvec_add(matrix, x, out):
    """out += M @ x (``matrix`` M); returns out."""
    return _rows(matrix, x, out, True)


@inline_jit
def matvec_t2(MT, x, y, out_x, out_y):
    """out_x = M @ x and out_y = M @ y of one matrix M (m, n) given transposed, ``MT`` (n, m),
    x and y (n,): each row's sum from 0.0 over the columns in order, as :func:`matvec`'s (the
    same to the bit), the rows' sums advanced together column by column, so the compiler
    vectorises them over the rows. For a tall matrix of few columns: the strips' motion,
    44 x 5 for the tanker, 54 ns where two :func:`matvec` took 106 ns."""
    n, m = MT.shape
    for i in range(m):
        out_x[i] = 0.0
        out_y[i] = 0.0
    for j in range(n):
        xj, yj = x[j], y[j]
        for i in range(m):
            a = MT[j, i]
            out_x[i] += a * xj
            out_y[i] += a * yj


@inline_jit
def dot(a, b):
    """a @ b for two vectors."""
    s = 0.0
    for i in range(a.size):
        s += a[i] * b[i]
    return s
