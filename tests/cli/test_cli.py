"""The command line: JSON outputs, one clear message and exit status 1 on bad input."""

import json
import math
import shutil
import subprocess
import sys

import pytest
import tomli_w

from postcapture.cli import main


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_simulate_json(capsys, tmp_path):
    out_file = tmp_path / "truth.nc"
    code, out, err = run(capsys, "simulate", "--duration", "2", "--json", "--out", str(out_file))
    assert code == 0, err
    summary = json.loads(out)
    for key in ("duration_s", "wall_s", "real_time_factor", "n_dof", "angular_momentum_drift_rel", "energy_drift_rel"):
        assert key in summary
    assert summary["n_dof"] == 25
    assert summary["duration_s"] == pytest.approx(2.0)
    assert out_file.exists()


def test_simulate_panel_segments_and_variants(capsys, tmp_path):
    code, out, _ = run(capsys, "simulate", "--duration", "0.5", "--panel-segments", "8", "--variant", "stiff",
                       "--json", "--out", str(tmp_path / "s.nc"))
    assert code == 0
    assert json.loads(out)["n_dof"] == 6 + 7 + 2 * (8 + 1)
    code, out, _ = run(capsys, "simulate", "--duration", "0.5", "--variant", "rigid", "--json", "--out", str(tmp_path / "r.nc"))
    assert code == 0
    assert json.loads(out)["n_dof"] == 6


def test_modes_json(capsys):
    code, out, _ = run(capsys, "modes", "--json", "--count", "5")
    assert code == 0
    modes = json.loads(out)["modes"]
    assert len(modes) == 5
    assert all(0.01 < m["frequency_hz"] < 1.0 for m in modes)
    assert modes[0]["dominant"] == "chaser_wing bending"


def _bad(tmp_path, envisat_dict, mutate):
    mutate(envisat_dict)
    path = tmp_path / "bad.toml"
    path.write_bytes(tomli_w.dumps(envisat_dict).encode())
    return str(path)


BAD_INPUTS = {
    "negative mass": (lambda d: d["chaser"].__setitem__("mass", -1.0), "chaser.mass: expected a number > 0"),
    "zero mass": (lambda d: d["target"].__setitem__("mass", 0.0), "target.mass: expected a number > 0"),
    "asymmetric inertia": (lambda d: d["chaser"]["inertia"][0].__setitem__(1, 5.0), "symmetric"),
    "indefinite inertia": (lambda d: d["chaser"].__setitem__("inertia", [[1, 0, 0], [0, 1, 0], [0, 0, -1]]), "positive definite"),
    "triangle inequality": (lambda d: d["chaser"].__setitem__("inertia", [[1, 0, 0], [0, 1, 0], [0, 0, 3]]), "triangle inequality"),
    "stiffness count": (lambda d: d["chaser"]["panels"][0].__setitem__("bending_stiffness", [1.0]), "expected 5 bending stiffnesses"),
    "unknown key": (lambda d: d.__setitem__("gravity", 9.81), "gravity: expected a known key"),
    "non-finite": (lambda d: d["initial"].__setitem__("omega_BN_B", [0.0, math.nan, 0.0]), "expected a finite number"),
}


@pytest.mark.parametrize("case", sorted(BAD_INPUTS))
def test_bad_scenario_exits_1_with_one_message(capsys, tmp_path, envisat_dict, case):
    mutate, expected = BAD_INPUTS[case]
    code, out, err = run(capsys, "simulate", "--scenario", _bad(tmp_path, envisat_dict, mutate), "--duration", "1")
    assert code == 1
    assert expected in err
    assert "Traceback" not in err and out == ""
    assert err.startswith("postcapture: error: invalid scenario")


def test_several_problems_in_one_message(capsys, tmp_path, envisat_dict):
    def mutate(d):
        d["chaser"]["mass"] = -1.0
        d["target"]["inertia"][0][1] = 7.0
        d["bogus"] = 1

    code, _, err = run(capsys, "modes", "--scenario", _bad(tmp_path, envisat_dict, mutate))
    assert code == 1
    assert "3 problems" in err and "chaser.mass" in err and "target.inertia" in err and "bogus" in err


def test_missing_file_and_unknown_name(capsys, tmp_path):
    code, _, err = run(capsys, "simulate", "--scenario", str(tmp_path / "none.toml"))
    assert code == 1 and "no such file" in err and "Traceback" not in err
    code, _, err = run(capsys, "modes", "--scenario", "jupiter")
    assert code == 1 and "unknown scenario name 'jupiter'" in err


def test_bad_option_value_exits_1(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--panel-segments", "0"])
    assert exc.value.code == 1
    assert "expected a number of panel segments in [1, 1000]" in capsys.readouterr().err


@pytest.mark.slow  # compiles the core from scratch and runs a short main job (about 30 s)
def test_bench_json_keys(capsys):
    code, out, _ = run(capsys, "bench", "--duration", "1.0", "--json")  # 1 s: the filters' shortest run
    assert code == 0
    result = json.loads(out)
    for key in ("rtf_n5", "rtf_n50", "rtf_n200", "rtf_n5_1arcsec", "predict_ms_n5", "predict_ms_n50", "compile_s",
                "main_job_s", "filter_rtf_joint_n5", "filter_rtf_dual_n5"):
        assert result[key] > 0


def test_installed_script_smoke(tmp_path):
    exe = shutil.which("postcapture") or str(__import__("pathlib").Path(sys.executable).parent / "postcapture")
    done = subprocess.run([exe, "--version"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and "postcapture" in done.stdout
    done = subprocess.run([exe, "simulate", "--duration", "0.3", "--json", "--out", str(tmp_path / "x.nc")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["n_dof"] == 25


def test_panel_calibrate_json_shape(capsys, tmp_path):
    code, out, err = run(capsys, "panel", "calibrate", "--panel", "chaser", "--weights", "0.1", "--json",
                         "--out", str(tmp_path / "cal"))
    assert code == 0, err
    result = json.loads(out)
    assert len(result["fem_hz"]) == 3
    run01 = result["runs"]["w=0.1"]
    for key in ("k", "k_torsion", "peak_hz", "fem_peak_hz", "mac"):
        assert key in run01
    assert len(run01["k"]) == 5 and min(run01["mac"]) > 0.99
    assert abs(run01["peak_hz"] / run01["fem_peak_hz"] - 1) < 0.01
    assert (tmp_path / "cal" / "calibration.json").exists() and (tmp_path / "cal" / "sweep_spectra.png").exists()


def test_panel_calibrate_bad_inputs_exit_1(capsys, tmp_path):
    code, _, err = run(capsys, "panel", "calibrate", "--panel", str(tmp_path / "missing.toml"))
    assert code == 1 and "expected envisat, chaser or an existing TOML file" in err and "Traceback" not in err
    with pytest.raises(SystemExit) as exc:
        main(["panel", "calibrate", "--weights", "1,-2"])
    assert exc.value.code == 1


def test_run_json_and_files(capsys, tmp_path):
    out = tmp_path / "res"
    code, stdout, err = run(capsys, "run", "--duration", "15", "--cases", "ekf_flexible,joint", "--no-crlb",
                            "--workers", "1", "--out", str(out), "--json")
    assert code == 0, err
    summary = json.loads(stdout)
    for name in ("ekf_flexible", "joint"):
        case = summary["cases"][name]
        for key in ("mass_error_kg", "mass_sigma_kg", "attitude_rms_arcsec", "attitude_inside_3sigma_fraction", "mass_inside_3sigma",
                    "nees_mean", "wall_s"):
            assert key in case
    assert summary["wall_s"] > 0
    for f in ("results.nc", "summary.json", "table.txt", "attitude_estimates.png", "mass_estimates.png"):
        assert (out / f).exists()


def test_run_bad_case_name_exits_1(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["run", "--cases", "ekf_flexible,kalman_magic"])
    assert exc.value.code == 1
    assert "expected case names among" in capsys.readouterr().err


def test_fmu_info_and_run_on_a_missing_fmu_exit_1(capsys, tmp_path):
    code, _, err = run(capsys, "fmu", "info", str(tmp_path / "none.fmu"))
    assert code == 1 and "none.fmu" in err and "no such file" in err and "Traceback" not in err
    code, _, err = run(capsys, "run", "--plant", f"fmu:{tmp_path / 'none.fmu'}", "--duration", "1", "--no-crlb",
                       "--workers", "1", "--out", str(tmp_path / "o"))
    assert code == 1 and "no such file" in err
    code, _, err = run(capsys, "run", "--plant", "simulink", "--duration", "1")
    assert code == 1 and "native or fmu:FILE.fmu" in err
