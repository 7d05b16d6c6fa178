"""The estimator FMU in FMI 3.0: the native case's estimates in fmpy (FMU3Slave) and in the Reference FMUs'
fmusim (a second FMI 3.0 master, built on this machine; skipped where it is absent), valid, and the bad
calls refused or counted as in FMI 2.0.

The FMUs (the recommended joint and dual, the reference's dual scheme with its EKF or MEKF) are exported for
the short scenario of ``test_estimator_fmu`` (seconds) and driven on the same recorded sensors as its native
cases.
"""

from __future__ import annotations

import csv
import ctypes
import subprocess

import numpy as np
import pytest

pytest.importorskip("fmpy")

from fmpy import extract, read_model_description  # noqa: E402
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.fmi3 import FMU3Slave  # noqa: E402
from test_estimator_fmu import Driver, _grids, _scenario, bad_states, missing_and_outliers  # noqa: E402
from test_masters import _read_csv, _tool  # noqa: E402

CASES = ("joint", "dual", "ekf_flexible", "mekf_flexible")
NAMES = ("target_mass", "target_mass_sigma", "q_BN_w", "q_BN_x", "q_BN_y", "q_BN_z", "attitude_sigma_x",
         "attitude_sigma_y", "attitude_sigma_z")


@pytest.fixture(scope="module")
def setup3(tmp_path_factory):
    """The FMI 3.0 FMUs, the plan, the recorded sensors and the native cases' estimates (NAMES' rows)."""
    from postcapture.core import rotations as rot
    from postcapture.studies.estimator_fmu import export_estimator_fmu
    from postcapture.studies.main_job import draw_sensors, run_case, simulate_truth
    from postcapture.studies.robust import with_model_noise
    from postcapture.studies.setup import plan_run

    sc = _scenario()
    folder = tmp_path_factory.mktemp("estimator3")
    fmus = {case: export_estimator_fmu(sc, folder / f"{case}3.fmu", case=case, fmi_version=3) for case in CASES}
    plan = with_model_noise(plan_run(sc, profile="reference", cases=CASES))
    traj = simulate_truth(plan)
    sensors, dq0 = draw_sensors(plan, traj, plan.seed)
    q_true0 = traj["q_BN"][:, 0]
    native = {}
    for case in CASES:
        run = run_case(plan, case, sensors, q_true0, dq0)
        sigma = np.sqrt(np.einsum("iik->ik", run.attitude.P)[:3])
        native[case] = np.vstack([run.mass, run.mass_sigma, run.attitude.q_BN, sigma])
    return plan, sensors, rot.box_plus(q_true0, dq0), fmus, native


class Driver3(Driver):
    """One instance of an FMI 3.0 estimator FMU through fmpy's FMU3Slave, with named variables."""

    def __init__(self, path, q0=None):
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmu = FMU3Slave(guid=self.md.guid, unzipDirectory=extract(str(path)),
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="estimator3")
        self.log = []  # the FMU's logged messages
        self.fmu.instantiate(logMessage=lambda env, status, category, message: self.log.append(message.decode()))
        self.fmu.enterInitializationMode(startTime=0.0)
        if q0 is not None:
            self.set({f"q0_BN_{a}": v for a, v in zip("wxyz", q0)})
        self.fmu.exitInitializationMode()

    def set(self, values: dict) -> None:
        self.fmu.setFloat64([self.vr[k] for k in values], [float(v) for v in values.values()])

    def get(self, *names) -> np.ndarray:
        return np.array(self.fmu.getFloat64([self.vr[n] for n in names]))


def _worst(got: np.ndarray, want: np.ndarray) -> dict:
    """The largest difference of each quantity relative to its largest magnitude (rows as NAMES)."""
    rows = {"mass": [0], "mass sigma": [1], "attitude": [2, 3, 4, 5], "attitude sigma": [6, 7, 8]}
    return {k: float(np.max(np.abs(got[r] - want[r])) / np.max(np.abs(want[r]))) for k, r in rows.items()}


@pytest.mark.parametrize("case", CASES)
def test_fmpy_reproduces_the_native_case(setup3, case):
    plan, sensors, q0, fmus, native = setup3
    drv = Driver3(fmus[case].path, q0=q0)
    star, gyro, accel, enc = _grids(sensors, plan.t_grid)
    dt = plan.t_grid[1] - plan.t_grid[0]
    hist = [drv.get(*NAMES)]
    for k in range(plan.t_grid.size - 1):
        drv.inputs(star[:, k + 1], gyro[:, k], accel[:, k], enc[:, k + 1])
        drv.fmu.doStep(currentCommunicationPoint=plan.t_grid[k], communicationStepSize=dt)
        hist.append(drv.get(*NAMES))
    assert drv.fmu.getFloat64([drv.vr["time"]])[0] == pytest.approx(plan.t_grid[-1], abs=1e-12)
    worst = _worst(np.array(hist).T, native[case])
    assert max(worst.values()) <= 1e-9, worst
    assert drv.get("recoveries", "diverged", "n_missing", "n_outliers").tolist() == [0, 0, 0, 0]


def _input_csv(path, plan, sensors) -> None:
    """fmusim's input file: at t_k the inputs of the step from t_k, as ``Driver.inputs`` sets them (the
    commanded inputs keep their start value, 0)."""
    star, gyro, accel, enc = _grids(sensors, plan.t_grid)
    rows = []
    for k in range(plan.t_grid.size - 1):
        values = {"time": plan.t_grid[k]}
        Driver.inputs(_Collect(values), star[:, k + 1], gyro[:, k], accel[:, k], enc[:, k + 1])
        rows.append(values)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(list(rows[0]))
        w.writerows([repr(float(v)) for v in row.values()] for row in rows)


class _Collect:
    """Stands in for a driver: ``Driver.inputs`` writes its values into a dict."""

    def __init__(self, into: dict):
        self.into = into

    def set(self, values: dict) -> None:
        self.into.update({k: float(v) for k, v in values.items()})


@pytest.mark.parametrize("case", CASES)
def test_fmusim_reproduces_the_native_case(setup3, case, tmp_path):
    """fmusim applies the CSV's discrete inputs at each communication point and writes %.16g."""
    exe = _tool("fmusim")
    plan, sensors, q0, fmus, native = setup3
    _input_csv(tmp_path / "in.csv", plan, sensors)
    out = tmp_path / "out.csv"
    args = [exe, "--interface-type", "cs", "--stop-time", repr(float(plan.t_grid[-1])), "--output-interval",
            repr(float(plan.t_grid[1] - plan.t_grid[0])), "--input-file", str(tmp_path / "in.csv"),
            "--output-file", str(out), "--log-level", "warning"]
    for a, v in zip("wxyz", q0):
        args += ["--start-value", f"q0_BN_{a}", repr(float(v))]
    for name in (*NAMES, "n_missing", "n_outliers"):
        args += ["--output-variable", name]
    proc = subprocess.run([*args, str(fmus[case].path)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0 and not proc.stderr.strip(), proc.stdout + proc.stderr
    t, Y = _read_csv(out, [*NAMES, "n_missing", "n_outliers"])
    assert t.size == plan.t_grid.size and np.abs(t - plan.t_grid).max() < 1e-9
    worst = _worst(Y[: len(NAMES)], native[case])
    assert max(worst.values()) <= 1e-9, worst
    assert not Y[len(NAMES):].any()


def test_valid_and_declares_its_capabilities(setup3):
    from fmpy.validation import validate_fmu

    from postcapture.fmi.description import read_description

    for report in setup3[3].values():
        assert report.fmi_version == "3.0"
        assert validate_fmu(str(report.path)) == []
        md = read_model_description(str(report.path))
        var = {v.name: v for v in md.modelVariables}
        assert md.fmiVersion == "3.0" and var["time"].causality == "independent"
        tunable = "R_star[1,1]" if report.case in ("ekf_flexible", "mekf_flexible") else "sigma_gyro"
        assert var[tunable].variability == "tunable" and var["q0_BN_w"].variability == "fixed"
        assert float(md.defaultExperiment.stepSize) == report.period
        flags = read_description(report.path).interface("co-simulation").flags
        assert flags["can_get_and_set_fmu_state"] and flags["can_serialize_fmu_state"]
        assert not flags["can_handle_variable_communication_step_size"]


def test_bad_calls_are_refused_or_counted(setup3):
    plan, sensors, q0, fmus, native = setup3
    drv = Driver3(fmus["joint"].path)
    star, gyro, accel, enc = _grids(sensors, plan.t_grid)
    dt = plan.t_grid[1] - plan.t_grid[0]
    with pytest.raises(FMICallException):  # a step other than the filter's period, with a logged reason
        drv.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=0.5 * dt)
    assert drv.log[-1].startswith("fmi3DoStep: communicationStepSize = 0.05") and "filter cycle" in drv.log[-1]
    with pytest.raises(FMICallException):  # a fixed parameter after initialisation
        drv.set({"q0_BN_w": 1.0})
    assert "q0_BN_w" in drv.log[-1]
    with pytest.raises(FMICallException):  # a tunable one out of its range: the call changes nothing
        drv.set({"sigma_gyro": 2e-3, "sigma_accel": -1.0})
    assert drv.get("sigma_gyro")[0] != 2e-3
    with pytest.raises(FMICallException):  # the independent variable
        drv.fmu.setFloat64([drv.vr["time"]], [1.0])
    missing_and_outliers(drv, plan, sensors)
    # states with a zero, non-unit or NaN quaternion and covariance are refused, set or deserialised
    state = drv.fmu.getFMUState()
    raw = bytes(drv.fmu.serializeFMUState(state))
    kept = drv.get(*NAMES)
    for bad in bad_states(raw):
        with pytest.raises(FMICallException, match="fmi3DeserializeFMUState"):
            drv.fmu.deserializeFMUState(bad)
    assert np.array_equal(drv.get(*NAMES), kept)
    data = np.frombuffer(raw[24:], dtype=np.float64).copy()
    data[-1] = np.nan  # the joint case's save ends with its covariance: a NaN variance, the quaternions kept
    with pytest.raises(FMICallException, match="fmi3DeserializeFMUState"):
        drv.fmu.deserializeFMUState(raw[:24] + data.tobytes())
    assert "covariance is not finite" in drv.log[-1]
    good = drv.fmu.deserializeFMUState(raw)
    drv.inputs(star[:, 3], gyro[:, 2], accel[:, 2], enc[:, 3])
    drv.fmu.doStep(currentCommunicationPoint=2 * dt, communicationStepSize=dt)
    drv.fmu.setFMUState(good)  # back to the saved cycle: the same estimates
    assert np.array_equal(drv.get(*NAMES), kept)
    for bad in bad_states(raw):  # the same bad data written into a state in memory
        ctypes.memmove(good.value, bad, len(bad))
        with pytest.raises(FMICallException, match="fmi3SetFMUState"):
            drv.fmu.setFMUState(good)
        assert "not a unit quaternion" in drv.log[-1] and np.array_equal(drv.get(*NAMES), kept)
    drv.fmu.freeFMUState(good)
    drv.fmu.freeFMUState(state)
    drv.fmu.terminate()
    drv.fmu.freeInstance()


def test_command_line_passes_the_fmi_version(monkeypatch, tmp_path, capsys):
    """``fmu export --estimator joint --fmi 3`` exports FMI 3.0 (the export itself is stubbed: the
    default scenario's filters take tens of seconds to derive)."""
    import json

    import postcapture.studies.estimator_fmu as module
    from postcapture.cli import main

    seen = {}

    def fake(scenario, out, **kw):
        seen.update(kw)
        return module.EstimatorExport(tmp_path / "x.fmu", kw["case"], kw["profile"], "{guid}", 0.1, (), "3.0")

    monkeypatch.setattr(module, "export_estimator_fmu", fake)
    assert main(["fmu", "export", "--estimator", "joint", "--fmi", "3", "-o", str(tmp_path / "x.fmu"), "--json"]) == 0
    assert seen["fmi_version"] == 3 and seen["case"] == "joint"
    assert json.loads(capsys.readouterr().out)["fmi_version"] == "3.0"


def test_an_unknown_fmi_version_is_refused_by_name(tmp_path):
    from postcapture.studies.estimator_fmu import export_estimator_fmu

    with pytest.raises(ValueError, match="fmi_version: expected 2 or 3, found 1"):
        export_estimator_fmu(_scenario(), tmp_path / "x.fmu", case="joint", fmi_version=1)
