"""The results files follow CF-1.10 and carry their provenance (issue 18): ``cfchecker`` reports no error on a
``simulate`` file, ``results.nc`` and ``campaign.nc``; vectors share their dimensions; ``results.nc`` holds
the CoM and inertia estimates and the sensor records; the JSON is strict."""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import postcapture as pc

CHECK = Path(__file__).resolve().parents[1] / "data" / "cf" / "cfchecks_1_10.py"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cf")
    sim = pc.simulate("envisat", duration=2.0).to_netcdf(folder / "sim.nc")
    run = pc.run("envisat", duration=3.0, cases=["ekf_flexible", "joint"], crlb=False, workers=1)
    run_paths = run.write(folder / "run")
    study = pc.campaign("envisat", runs=2, dispersed=True, cases=["joint"], duration=3.0, workers=0, crlb=False)
    camp_paths = study.write(folder / "camp", figures=False)
    return {"sim": sim, "run": run_paths["results"], "campaign": camp_paths["results"],
            "run_summary": run_paths["summary"], "campaign_summary": camp_paths["summary"], "run_result": run}


@pytest.mark.parametrize("which", ["sim", "run", "campaign"])
def test_cfchecker_reports_no_error(files, which):
    done = subprocess.run([sys.executable, str(CHECK), str(files[which])], capture_output=True, text=True, timeout=300)
    assert "Traceback" not in done.stderr + done.stdout, done.stdout + done.stderr
    assert "ERRORS detected: 0" in done.stdout and "WARNINGS given: 0" in done.stdout, done.stdout
    assert done.returncode == 0, done.stdout


def test_vectors_share_their_dimensions(files):
    with xr.open_dataset(files["sim"]) as ds:
        assert set(ds.sizes) == {"time", "axis", "quaternion", "quaternion_xyzw", "arm_joint", "joint"}, dict(ds.sizes)
        assert ds["omega_BN_B"].dims == ds["accel_B"].dims == ds["r_BN_N"].dims == ("axis", "time")
        assert ds["energy"].dims == ("time",)  # a one-component "vector" is a plain series
        assert ds.attrs["Conventions"] == "CF-1.10"


def test_results_hold_target_estimates_and_sensor_records(files):
    from postcapture.io.netcdf import label_index

    with xr.open_dataset(files["run"]) as ds:
        joint = label_index(ds, "case", "joint")
        com = ds["com_est"].isel(case=joint).values
        assert ds["com_est"].attrs["units"] == "m" and np.isfinite(com[:, -1]).all()
        assert ds["inertia_est"].attrs["units"] == "kg m2" and ds["inertia_true"].shape == (6,)
        # the truth is the nominal scenario here; the filters start 100 kg light (the hub's CoM is where the nominal
        # one is), so the whole target's CoM starts within a centimetre and its inertia within 2 %
        assert np.all(np.abs(com[:, 0] - ds["com_true"].values) < 0.01)
        inertia = ds["inertia_est"].isel(case=joint).values
        assert np.allclose(inertia[:3, 0], ds["inertia_true"].values[:3], rtol=0.02)
        assert np.isnan(ds["com_est"].isel(case=label_index(ds, "case", "ekf_flexible")).values).all()
        for name, dim in (("star_tracker", "quaternion"), ("gyro", "axis"), ("accelerometer", "axis"),
                          ("joint_encoders", "arm_joint")):
            assert ds[name].dims == (dim, "time") and ds[f"{name}_valid"].dims == ("time",)
        assert ds["joint_encoders"].attrs["units"] == "rad"
        # the encoders read the link angle to a count of 2 pi / 2^20 and their noise
        assert np.allclose(ds["joint_encoders"].values[:, 1:], files["run_result"].result.truth["arm_q"][:, 1:],
                           atol=1e-4)
        assert ds["gyro"].attrs["units"] == "rad/s" and ds["accelerometer"].attrs["units"] == "m/s^2"
        # the recorded gyro is what the filters read: close to the truth's body rate
        assert np.allclose(ds["gyro"].values[:, 1:], files["run_result"].result.truth["omega_BN_B"][:, 1:], atol=1e-3)


@pytest.mark.parametrize("which", ["sim", "run", "campaign"])
def test_every_file_records_its_provenance(files, which):
    with xr.open_dataset(files[which]) as ds:
        a = ds.attrs
        assert a["postcapture_version"] == pc.__version__ and a["date_created"].endswith("+00:00")
        assert a["command_line"] and a["source_commit"] and "history" in a
        if which != "sim":
            assert 'name = "envisat"' in a["scenario_toml"]
            assert pc.load_scenario("envisat").model_dump() == _scenario_from(a["scenario_toml"]).model_dump()


def _scenario_from(text):
    import tomllib

    from postcapture.config import scenario_from_dict

    return scenario_from_dict(tomllib.loads(text))


@pytest.mark.parametrize("which", ["run_summary", "campaign_summary"])
def test_summary_json_is_strict_with_provenance(files, which):
    def refuse(token):
        raise AssertionError(f"non-standard JSON constant {token}")

    doc = json.loads(Path(files[which]).read_text(), parse_constant=refuse)
    assert doc["provenance"]["postcapture_version"] == pc.__version__
    assert "scenario_toml" in doc["provenance"]

    def no_nan(x):
        if isinstance(x, float):
            assert math.isfinite(x)
        elif isinstance(x, dict):
            [no_nan(v) for v in x.values()]
        elif isinstance(x, list):
            [no_nan(v) for v in x]

    no_nan(doc)


def test_cli_json_prints_null_not_nan(tmp_path, capsys):
    """``--json`` printed ``NaN``; a case without a 0.1 % settling time or with a NaN metric prints null."""
    from postcapture.cli import main

    code = main(["run", "--duration", "3", "--cases", "ekf_flexible", "--workers", "1", "--no-crlb", "--no-plots",
                 "--json", "--out", str(tmp_path / "r")])
    out = capsys.readouterr().out
    assert code == 0 and "NaN" not in out and "Infinity" not in out
    json.loads(out, parse_constant=lambda t: (_ for _ in ()).throw(AssertionError(t)))


def test_the_run_report_is_one_page_with_what_a_review_needs(files):
    report = (Path(files["run"]).parent / "report.md").read_text()
    for heading in ("# Main job: scenario envisat", "## Provenance", "## Consistency", "## Table", "## Every metric",
                    "## Figures"):
        assert heading in report, heading
    assert f"postcapture {pc.__version__}" in report and "![mass estimates](mass_estimates.png)" in report
    # every scalar metric of every case is a row, whatever metrics the estimation side adds
    summary = json.loads(Path(files["run_summary"]).read_text())
    for key, value in summary["cases"]["joint"].items():
        if not isinstance(value, (list, dict)):
            assert f"| `{key}` |" in report, key
