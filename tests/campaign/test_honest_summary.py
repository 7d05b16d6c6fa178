"""A campaign summary counts every run: a diverged run's last estimate enters the RMS and counts as outside its
3 sigma, and the NEES is given over all runs and over the survivors (against a hand computation)."""

import numpy as np
import pytest

from postcapture.studies.campaign_result import CampaignResult, summarize


def _run(r, err, sig, diverged_at=float("nan"), att_nees=3.0):
    n = 11
    e = np.full(n, err, dtype=float)
    s = np.full(n, sig, dtype=float)
    c = {"mass_error": e, "mass_sigma": s, "attitude_nees": np.full(n, att_nees), "diverged_at": diverged_at,
         "com_error": np.zeros(3), "com_sigma": np.ones(3), "inertia_error": np.zeros(6), "inertia_sigma": np.ones(6),
         "message": ""}
    return {"run": r, "truth": np.zeros(1), "true_mass": 1000.0, "cases": {"joint": c}}


def test_a_diverged_run_counts_in_the_rms_and_as_a_miss():
    runs = [_run(0, 1.0, 1.0), _run(1, -2.0, 1.0), _run(2, 30.0, 1.0, diverged_at=0.5, att_nees=100.0)]
    result = CampaignResult({"cases": ["joint"], "dispersed": True}, np.linspace(0.0, 1.0, 11), runs, ("x",))
    c = summarize(result)["cases"]["joint"]
    assert c["mass_error_rms_kg"] == pytest.approx(np.sqrt((1 + 4 + 900) / 3))
    assert c["mass_error_rms_survivors_kg"] == pytest.approx(np.sqrt((1 + 4) / 2))
    assert c["inside_3sigma_fraction"] == pytest.approx(2 / 3) and c["diverged_runs"] == 1
    # NEES: over all runs (1, 4, 900 at every instant) and over the two survivors
    assert c["nees_mean"] == pytest.approx((1 + 4 + 900) / 3)
    assert c["nees_mean_survivors"] == pytest.approx(2.5)
    assert c["attitude_nees_mean"] == pytest.approx((3 + 3 + 100) / 3)
    assert c["attitude_nees_mean_survivors"] == pytest.approx(3.0)
    assert c["com_inside_3sigma_fraction"] == pytest.approx(2 / 3)  # the diverged run's components count as outside
