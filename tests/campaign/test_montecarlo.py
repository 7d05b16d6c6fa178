"""Monte Carlo on Dask: the plumbing on a short run (the 50-seed consistency check is slow)."""

import numpy as np
import pytest

from postcapture.campaign.montecarlo import monte_carlo
from postcapture.core.consistency import chi2_bounds


def test_seeds_give_independent_noise_and_a_summary(envisat):
    res = monte_carlo(envisat, profile="realistic", cases=("mekf_flexible",), seeds=[1, 2, 3], duration=5.0)
    nees = res.nees["mekf_flexible"]
    assert nees.shape == (3, res.t.size)
    assert not np.allclose(nees[0], nees[1])  # different seeds, different noise
    s = res.summary()
    assert s["n_seeds"] == 3 and s["nees_band_95"] == list(chi2_bounds(3, 3))
    assert np.isfinite(s["cases"]["mekf_flexible"]["nees_mean"])


@pytest.mark.slow
def test_fifty_seed_consistency_of_ekf_and_mekf(envisat):
    """Over 50 seeds of sensor noise on one truth, the mean attitude NEES lies in the 95 % band."""
    res = monte_carlo(envisat, profile="realistic", cases=("ekf_flexible", "mekf_flexible"), seeds=range(50))
    s = res.summary()
    lo, hi = s["nees_band_95"]
    for name in ("ekf_flexible", "mekf_flexible"):
        c = s["cases"][name]
        print(name, c)
        assert lo <= c["nees_mean"] <= hi, (name, c["nees_mean"], (lo, hi))
