"""Sample instants and matching them against other grids."""

import numpy as np
import pytest

from postcapture.core.errors import TimeGridError
from postcapture.core.timegrid import match_times, merge_times, sample_times


def test_sample_times_do_not_accumulate_and_include_the_end():
    t = sample_times(0.0, 10.0, 10.0)
    assert t.size == 101 and t[-1] == 10.0
    assert np.array_equal(t, np.arange(101) / 10.0)


def test_match_times_tolerates_rounding_but_not_offsets():
    grid = 0.001 * np.arange(10001)  # 1 ms truth grid
    idx = match_times(sample_times(0.0, 10.0, 3.0 / 0.3), grid)
    assert np.array_equal(idx, np.arange(0, 10001, 100))
    with pytest.raises(TimeGridError, match="3 of 3 instants are not on the time grid"):
        match_times([0.0005, 1.0005, 2.0005], grid, name="gyro")


def test_merge_times_identifies_equal_instants():
    t, (i1, i2) = merge_times([0.0, 0.1, 0.2, 0.30000000000000004], [0.0, 0.15, 0.3])
    assert np.allclose(t, [0.0, 0.1, 0.15, 0.2, 0.3])
    assert list(i1) == [0, 1, 3, 4] and list(i2) == [0, 2, 4]
