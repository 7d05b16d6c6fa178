"""The run table says what it shows: a diverged filter's sigma is not printed as if it meant something."""

from postcapture.report.table import results_table


def _case(error, sigma, success=True, message=None):
    return {"mass_error_kg": error, "mass_sigma_kg": sigma, "settle_1pct_s": None, "settle_01pct_s": None,
            "wall_s": 1.0, "attitude_rms_arcsec": 1.0, "attitude_rms_steady_arcsec": 1.0,
            "attitude_inside_3sigma_fraction": 0.99, "nees_mean": 3.0, "nis_mean": 3.0, "success": success,
            "message": message}


def _summary():
    return {"scenario": "envisat", "profile": "reference", "seed": 1, "duration_s": 10.0, "true_mass_kg": 7827.9,
            "initial_mass_kg": 7727.9, "wall_s": 2.0, "truth_wall_s": 0.5,
            "cases": {"joint": _case(-3.5, 19.8),
                      "ekf_stiff": _case(1172.1, 3.7e-5, False, "filter 'ekf_stiff/mass' diverged at t = 35 s")}}


def test_a_diverged_case_shows_diverged_instead_of_its_sigma():
    rows = {}
    for line in results_table(_summary()).splitlines():  # the mass table's rows come first
        if line.strip():
            rows.setdefault(line.split()[0], line)
    assert "diverged" in rows["ekf_stiff"].split() and "0.000111" not in rows["ekf_stiff"]
    assert "59.4" in rows["joint"].split()  # a healthy case keeps its 3 sigma
    assert "ekf_stiff: filter 'ekf_stiff/mass' diverged at t = 35 s" in results_table(_summary())
