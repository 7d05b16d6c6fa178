"""Consistency metrics and the Bar-Shalom chi-square bounds."""

import numpy as np
import pytest

from postcapture.core.consistency import chi2_bounds, fraction_inside, nees, nis, rms
from postcapture.core.errors import DimensionError


@pytest.mark.parametrize(
    "dim, lo, hi",  # table of physical-data.md (Bar-Shalom, two-sided 95 %, N = 50 runs)
    [(3, 2.36, 3.72), (6, 5.08, 7.00), (1, 0.65, 1.43), (10, 8.80, 11.28)],
)
def test_bounds_match_the_bar_shalom_table(dim, lo, hi):
    b = chi2_bounds(dim, 50)
    assert b[0] == pytest.approx(lo, abs=0.005) and b[1] == pytest.approx(hi, abs=0.005)


def test_bounds_single_run_are_chi2_quantiles():
    lo, hi = chi2_bounds(2, alpha=0.05)
    assert lo == pytest.approx(0.0506356, rel=1e-5) and hi == pytest.approx(7.377759, rel=1e-6)


def test_nees_of_gaussian_samples_averages_to_the_dimension():
    rng = np.random.default_rng(21)
    n, k = 4, 20000
    A = rng.standard_normal((n, n))
    P = A @ A.T + np.eye(n)
    e = np.linalg.cholesky(P) @ rng.standard_normal((n, k))
    values = nees(e, np.repeat(P[:, :, None], k, axis=2))
    assert values.shape == (k,)
    assert np.mean(values) == pytest.approx(n, rel=0.02)
    assert nees(e[:, 0], P) == pytest.approx(e[:, 0] @ np.linalg.solve(P, e[:, 0]))
    assert nis(e[:, 0], P) == nees(e[:, 0], P)


def test_nees_is_nan_where_data_are_missing_and_checks_shapes():
    e = np.ones((2, 3))
    e[0, 1] = np.nan
    P = np.repeat(np.eye(2)[:, :, None], 3, axis=2)
    out = nees(e, P)
    assert np.isnan(out[1]) and out[0] == pytest.approx(2.0)
    with pytest.raises(DimensionError, match=r"P matrix; expected \(2, 2, 3\) but found \(2, 2\)"):
        nees(e, np.eye(2))


def test_rms_and_three_sigma_share():
    e = np.array([[1.0, -1.0, 1.0, -1.0], [0.0, 0.0, 3.0, np.nan]])
    assert np.allclose(rms(e), [1.0, np.sqrt(3.0)])
    sigma = np.ones_like(e) * np.array([[0.5], [1.0]])
    assert np.allclose(fraction_inside(e, sigma, n_sigma=3.0), [1.0, 1.0])
    assert np.allclose(fraction_inside(e, sigma, n_sigma=1.0), [0.0, 2.0 / 3.0])


def test_three_sigma_share_of_gaussian_noise():
    rng = np.random.default_rng(22)
    e = rng.standard_normal((2, 200000)) * np.array([[2.0], [0.1]])
    share = fraction_inside(e, np.ones_like(e) * np.array([[2.0], [0.1]]))
    assert np.allclose(share, 0.9973, atol=0.001)


def test_run_averaged_nees_leaves_out_each_run_from_its_divergence():
    from postcapture.core.consistency import run_averaged_nees

    t = np.array([0.0, 1.0, 2.0, 3.0])
    nees = np.array([[1.0, 2.0, 3.0, 4.0],
                     [3.0, 1e30, 1e30, 1e30],   # diverged at t = 1: its absurd values are left out
                     [5.0, 6.0, 7.0, 8.0]])
    out = run_averaged_nees(nees, t, [np.nan, 1.0, np.nan])
    np.testing.assert_allclose(out, [3.0, 4.0, 5.0, 6.0])
    # every run stopped: NaN, no warning
    assert np.isnan(run_averaged_nees(nees[1:2], t, [0.0])).all()
    # the input is not changed
    assert nees[1, 1] == 1e30
