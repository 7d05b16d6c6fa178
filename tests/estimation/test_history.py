"""The EstimateHistory record."""

import numpy as np
import pytest

from postcapture.core import rotations as rot
from postcapture.core.errors import DimensionError
from postcapture.estimation import EstimateHistory, StepFlag


def make(n=4, **kw):
    args = dict(
        filter_name="f", t=np.arange(n) * 0.1, q_BN=np.repeat(rot.IDENTITY[:, None], n, axis=1),
        P=np.repeat(np.diag([4.0, 9.0])[:, :, None], n, axis=2), nis=np.full(n, np.nan),
        flags=np.array([StepFlag.UPDATED, StepFlag.REJECTED | StepFlag.INPUT_MISSING, 0, 0][:n], np.uint8),
        error_labels=("a", "b"),
    )
    args.update(kw)
    return EstimateHistory(**args)


def test_sigmas_flags_and_nees():
    h = make()
    assert np.allclose(h.sigmas, [[2.0] * 4, [3.0] * 4])
    assert list(h.flagged(StepFlag.REJECTED)) == [False, True, False, False]
    assert list(h.flagged(StepFlag.INPUT_MISSING)) == [False, True, False, False]
    assert np.allclose(h.nees(np.full((1, 4), 2.0)), 1.0)
    assert np.allclose(h.nees(np.array([[2.0] * 4, [3.0] * 4])), 2.0)


def test_shapes_are_checked():
    with pytest.raises(DimensionError, match=r"EstimateHistory.P: expected shape \(2, 2, 4\)"):
        make(P=np.zeros((2, 2, 3)))
    with pytest.raises(DimensionError, match="states"):
        make(states={"bias": np.zeros((3, 5))})
