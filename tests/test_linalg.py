"""The compiled loop's small products (flexlift.ascent.linalg) against each other, to the bit,
and against NumPy; the strips' transposed shape against their shape, in both plants."""

import numpy as np
import pytest

from flexlift.ascent.linalg import matvec, matvec_add, matvec_t2


@pytest.mark.parametrize("m, n", [(44, 5), (7, 5), (73, 9), (5, 44), (1, 1), (3, 0), (0, 4)])
def test_the_transposed_pair_is_two_products_to_the_bit(m, n):
    """matvec_t2 on M given transposed: each row's sum is matvec's, bit for bit (its signed
    zeros too: a row of -0.0 products is +0.0 in both), and NumPy's to rounding."""
    rng = np.random.default_rng(m * 100 + n)
    M = rng.normal(size=(m, n)) * 10.0 ** rng.integers(-3, 4, size=(m, n))
    if m > 1 and n > 0:
        M[1] = -0.0  # a row of negative zeros
    x, y = rng.normal(size=n), rng.normal(size=n)
    got_x, got_y = np.full(m, np.nan), np.full(m, np.nan)
    matvec_t2(np.ascontiguousarray(M.T), x, y, got_x, got_y)
    want_x, want_y = matvec(M, x, np.full(m, np.nan)), matvec(M, y, np.full(m, np.nan))
    assert got_x.tobytes() == want_x.tobytes() and got_y.tobytes() == want_y.tobytes()
    np.testing.assert_allclose(got_x, M @ x, rtol=1e-12, atol=1e-12 * np.abs(M).sum())
    added = np.ones(m)
    matvec_add(M, x, added)
    np.testing.assert_allclose(added, 1.0 + M @ x, rtol=1e-12, atol=1e-12 * np.abs(M).sum())


@pytest.mark.parametrize("kind", ["coupled", "paper"])
def test_the_strips_transposed_shape_is_their_shape(kind):
    from flexlift import load_scenario
    from flexlift.ascent.paper import paper_plant
    from flexlift.ascent.plant import coupled_plant

    sc = load_scenario("tanker")
    strips = (coupled_plant if kind == "coupled" else paper_plant)(sc).records.strips
    assert strips.shape_t.flags.c_contiguous
    np.testing.assert_array_equal(strips.shape_t, strips.shape.T)
