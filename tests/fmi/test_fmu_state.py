"""Get, set and serialise the FMU state: a restored run repeats the original bit for bit, and a state
holding a zero, non-unit or NaN quaternion is refused.

FMPy's test_fmu_state.py is the model; the state is restored in the same instance and in a fresh one.
"""

import ctypes
import math

import numpy as np
import pytest

import fmpy

from fmpy.fmi2 import FMU2Slave  # noqa: E402

H = 0.1


def _instance(report, tmp_path, name):
    md = fmpy.read_model_description(str(report.path))
    unzip = fmpy.extract(str(report.path), str(tmp_path / name))
    fmu = FMU2Slave(
        guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier, instanceName=name
    )
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    state = [v.valueReference for v in md.modelVariables if v.name.startswith(("q[", "v["))]
    out = state + [vr["accel_B_x"], vr["arm_ddq_2"], vr["tip_envisat_wing_z"]]
    return fmu, out, vr


def _run(fmu, out, k0, k1):
    rows = []
    for k in range(k0, k1):
        fmu.doStep(k * H, H)
        rows.append(fmu.getReal(out))
    return np.array(rows)


def test_set_state_repeats_the_run(envisat_fmu, tmp_path):
    fmu, out, vr = _instance(envisat_fmu, tmp_path, "a")
    _run(fmu, out, 0, 100)  # to t = 10 s, where the joint sines start
    state = fmu.getFMUstate()
    first = _run(fmu, out, 100, 140)
    fmu.setFMUstate(state)
    again = _run(fmu, out, 100, 140)
    assert np.array_equal(first, again)
    # a changed parameter and a correction are part of the state too
    fmu.setFMUstate(state)
    fmu.setReal([vr["target.m"]], [6000.0])
    changed = _run(fmu, out, 100, 110)
    assert not np.array_equal(changed, first[:10])
    fmu.setFMUstate(state)
    assert np.array_equal(_run(fmu, out, 100, 140), first)
    fmu.freeFMUstate(state)
    fmu.terminate()
    fmu.freeInstance()


def test_serialized_state_restores_in_a_fresh_instance(envisat_fmu, tmp_path):
    fmu, out, _ = _instance(envisat_fmu, tmp_path, "b")
    _run(fmu, out, 0, 120)
    state = fmu.getFMUstate()
    blob = fmu.serializeFMUstate(state)
    fmu.freeFMUstate(state)
    first = _run(fmu, out, 120, 150)
    fmu.terminate()
    fmu.freeInstance()

    other, out2, _ = _instance(envisat_fmu, tmp_path, "c")
    restored = other.deSerializeFMUstate(blob)
    other.setFMUstate(restored)
    other.freeFMUstate(restored)
    assert np.array_equal(_run(other, out2, 120, 150), first)
    other.terminate()
    other.freeInstance()


def test_foreign_serialized_state_is_refused(envisat_fmu, rigid_plain_fmu, tmp_path):
    fmu, _, _ = _instance(envisat_fmu, tmp_path, "d")
    blob = fmu.serializeFMUstate(fmu.getFMUstate())
    other, _, _ = _instance(rigid_plain_fmu, tmp_path, "e")
    with pytest.raises(fmpy.fmi1.FMICallException, match="fmi2DeSerializeFMUstate"):
        other.deSerializeFMUstate(blob)


QUAT = 2 + 3  # the state's doubles: time, last successful time, then x = [position (3), quaternion (4), ...]
BAD_QUATERNIONS = [(0.0, 0.0, 0.0, 0.0), (0.5, 0.5, 0.5, 0.2), (math.nan, 0.0, 0.0, 1.0)]


@pytest.mark.parametrize("quat", BAD_QUATERNIONS)
def test_deserialized_state_with_a_bad_quaternion_is_refused(envisat_fmu, tmp_path, quat):
    fmu, out, _ = _instance(envisat_fmu, tmp_path, "f")
    _run(fmu, out, 0, 5)
    blob = bytearray(fmu.serializeFMUstate(fmu.getFMUstate()))
    header = 16  # magic, version, size, GUID hash (4 x uint32)
    good = np.frombuffer(bytes(blob[header:]), dtype=np.float64, count=QUAT + 4)
    assert abs(np.linalg.norm(good[QUAT:]) - 1.0) < 1e-12  # the layout this test assumes
    blob[header + 8 * QUAT : header + 8 * (QUAT + 4)] = np.array(quat, dtype=np.float64).tobytes()
    with pytest.raises(fmpy.fmi1.FMICallException, match="fmi2DeSerializeFMUstate"):
        fmu.deSerializeFMUstate(bytes(blob))
    before = _run(fmu, out, 5, 6)  # the instance steps on from its own state
    assert np.isfinite(before).all()
    fmu.terminate()
    fmu.freeInstance()


@pytest.mark.parametrize("quat", BAD_QUATERNIONS)
def test_set_state_with_a_bad_quaternion_is_refused(envisat_fmu, tmp_path, quat):
    """A state changed in memory (what a corrupted or foreign pointer would hold) is checked before use;
    the instance keeps its own state and steps on."""
    fmu, out, _ = _instance(envisat_fmu, tmp_path, "g")
    _run(fmu, out, 0, 5)
    state = fmu.getFMUstate()
    x = np.ctypeslib.as_array(ctypes.cast(state, ctypes.POINTER(ctypes.c_double)), shape=(QUAT + 4,))
    assert abs(np.linalg.norm(x[QUAT:]) - 1.0) < 1e-12  # the layout this test assumes
    x[QUAT:] = quat
    _run(fmu, out, 5, 6)
    kept = fmu.getReal(out)
    with pytest.raises(fmpy.fmi1.FMICallException, match="fmi2SetFMUstate"):
        fmu.setFMUstate(state)
    assert fmu.getReal(out) == kept
    assert np.isfinite(_run(fmu, out, 6, 7)).all()
    fmu.freeFMUstate(state)
    fmu.terminate()
    fmu.freeInstance()
