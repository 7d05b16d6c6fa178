"""The plant as an FMI 3.0 co-simulation FMU: valid, the same trajectory and Jacobians as the native model
in fmpy, directional derivatives through fmi3GetDirectionalDerivative, and checked FMU states."""

import math

import numpy as np
import pytest

import fmpy
from fmpy.fmi3 import FMU3Slave

from fmi_helpers import native_model, native_trajectory, rel, state_names  # noqa: E402

from postcapture.dynamics.build import build_system  # noqa: E402
from postcapture.fmi import FMUProcessModel  # noqa: E402
from postcapture.fmi.description import read_description  # noqa: E402


def test_valid_and_declares_its_capabilities(envisat_fmu3, envisat):
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(envisat_fmu3.path)) == []
    flags = read_description(envisat_fmu3.path).interface("co-simulation").flags  # FMPy drops the FMI 3 spelling
    assert flags["provides_directional_derivatives"] and flags["can_handle_variable_communication_step_size"]
    assert flags["can_get_and_set_fmu_state"] and flags["can_serialize_fmu_state"]
    md = fmpy.read_model_description(str(envisat_fmu3.path))
    var = {v.name: v for v in md.modelVariables}
    assert md.fmiVersion == "3.0" and var["time"].causality == "independent"
    assert all(var[n].causality == "input" for n in build_system(envisat).parameter_names)
    assert var["der(q[1])"].derivative is var["q[1]"]
    assert envisat_fmu3.fmi_version == "3.0"


@pytest.mark.parametrize("dt", [0.1, 0.01])
def test_fmpy_run_matches_native(envisat_fmu3, envisat, dt):
    """fmpy drives the FMI 3.0 FMU over 5 s at 0.1 s and at 0.01 s (shorter than the internal step): the
    native process model at the same internal steps agrees to 1e-12."""
    system = build_system(envisat)
    names = state_names(system)
    res = fmpy.simulate_fmu(str(envisat_fmu3.path), stop_time=5.0, output_interval=dt, output=names)
    Y = np.array([res[n] for n in names])
    X = native_trajectory(system, envisat_fmu3, 5.0, dt)
    assert Y.shape == X.shape
    assert rel(Y, X) <= 1e-12


def test_process_model_on_fmi3(envisat_fmu3, envisat):
    """The filters' process model on the FMI 3.0 FMU: Jacobian outputs as the native ones, and the
    directional path (fmi3GetDirectionalDerivative, parameter inputs as knowns) exact on H and Hp."""
    native = native_model(build_system(envisat), envisat_fmu3.step, envisat_fmu3.integrator)
    x = native.initial_state()
    for k in range(150):
        x = native.predict(x, k * 0.1, 0.1).x
    ref = native.predict(x, 15.0, 0.1, jacobians=True)
    with FMUProcessModel(envisat_fmu3.path) as model:
        assert model.capabilities["fmi_version"] == "3.0" and model.jacobian_method == "outputs"
        got = model.predict(x, 15.0, 0.1, jacobians=True)
    for name in ("x", "z", "F", "g", "H", "h", "G", "Hp"):
        assert rel(getattr(got, name), getattr(ref, name)) <= 1e-12, name
    with FMUProcessModel(envisat_fmu3.path, jacobians="directional") as model:
        got = model.predict(x, 15.0, 0.1, jacobians=True)
    assert rel(got.H, ref.H) <= 1e-8 and rel(got.Hp, ref.Hp) <= 1e-8


@pytest.fixture
def slave3(envisat_fmu3, tmp_path):
    md = fmpy.read_model_description(str(envisat_fmu3.path))
    unzip = fmpy.extract(str(envisat_fmu3.path), str(tmp_path / "unz3"))
    fmu = FMU3Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate()
    fmu.enterInitializationMode(startTime=0.0)
    fmu.exitInitializationMode()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    yield fmu, vr
    fmu.terminate()
    fmu.freeInstance()


def test_bad_calls_are_refused(slave3):
    """A non-finite step, a bad parameter and a state with a zero quaternion: fmi3Error, state kept."""
    fmu, vr = slave3
    states = [vr[f"q[{i}]"] for i in range(1, 8)]
    fmu.doStep(0.0, 0.1)
    kept = fmu.getFloat64(states)
    for call in (lambda: fmu.doStep(0.1, math.nan), lambda: fmu.setFloat64([vr["target.m"]], [-1.0])):
        with pytest.raises(fmpy.fmi1.FMICallException):
            call()
    blob = bytearray(fmu.serializeFMUState(fmu.getFMUState()))
    blob[16 + 8 * 5 : 16 + 8 * 9] = bytes(32)  # the quaternion q[4..7] after the header and t, t_ok, q[1..3]
    with pytest.raises(fmpy.fmi1.FMICallException, match="fmi3DeserializeFMUState"):
        fmu.deserializeFMUState(bytes(blob))
    assert fmu.getFloat64(states) == kept
    fmu.doStep(0.1, 1.95e-14)  # a master's last sliver of a step
    assert fmu.getFloat64([vr["time"]]) == [0.1 + 1.95e-14]


def test_command_line_export(tmp_path, capsys):
    """``postcapture fmu export --fmi 3`` (in process), the rigid plant for speed."""
    import json

    from postcapture.cli import main

    out = tmp_path / "rigid3.fmu"
    assert main(["fmu", "export", "--fmi", "3", "--variant", "rigid", "-o", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["fmi_version"] == "3.0" and out.is_file()
    assert read_description(out).interface("co-simulation").flags["provides_directional_derivatives"]
