"""The dual EKF on the exported FMU gives the native run's estimates, no slower than twice its time."""

import numpy as np

from postcapture.studies.main_job import run_main_job


def test_dual_ekf_on_fmu_matches_native(envisat, envisat_fmu):
    runs = {
        plant: run_main_job(envisat, profile="reference", cases=("ekf_flexible",), crlb=False, workers=1,
                            plant=plant, duration=60.0)
        for plant in ("native", f"fmu:{envisat_fmu.path}")
    }
    a = runs["native"].cases["ekf_flexible"].result
    b = runs[f"fmu:{envisat_fmu.path}"].cases["ekf_flexible"].result
    assert np.abs(a.mass - b.mass).max() / np.abs(a.mass).max() <= 1e-6
    assert np.abs(a.mass_sigma - b.mass_sigma).max() / np.abs(a.mass_sigma).max() <= 1e-6
    assert np.abs(a.attitude.q_BN - b.attitude.q_BN).max() <= 1e-6
    assert b.wall_s <= 2.0 * a.wall_s + 1.0, (a.wall_s, b.wall_s)
