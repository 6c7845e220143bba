"""The single-point fast path of FIS.__call__ gives exactly the general path's answers."""

import numpy as np
import pytest

from flexlift.errors import InputError
from flexlift.fuzzy.rulebase import supervisor_fis


@pytest.mark.parametrize("and_method", ["min", "prod"])
@pytest.mark.parametrize("implication", ["min", "prod"])
def test_fast_single_point_equals_batch(and_method, implication):
    fis = supervisor_fis(and_method=and_method, implication=implication)
    assert fis._single_point is not None
    rng = np.random.default_rng(7)
    pts = rng.uniform(-1.4, 1.4, size=(300, 2))  # some beyond the universe: saturated
    batch = fis(pts)  # the general vectorised path
    single = np.array([fis(p) for p in pts])  # ndarray rows take the fast path
    as_tuple = np.array([fis(tuple(p.tolist())) for p in pts])
    np.testing.assert_allclose(single, batch, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(single, as_tuple)


def test_other_operators_fall_back_to_the_general_path():
    assert supervisor_fis(defuzzification="bisector")._single_point is None
    assert supervisor_fis(aggregation="sum")._single_point is None


def test_fast_path_rejects_nan():
    fis = supervisor_fis()
    with pytest.raises(InputError, match="NaN"):
        fis(np.array([np.nan, 0.1]))
    with pytest.raises(InputError, match="NaN"):
        fis((0.2, float("nan")))
