"""Calls on the exported FMU: any positive communication step is taken in equal internal steps (the
native model at that step agrees), the Jacobian outputs are finite with their validity flag; bad calls
are each refused with fmi2Error and a logged message naming the variable, the state is kept, and a
failed step leaves the instance in the error state."""

import math

import numpy as np
import pytest

import fmpy
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave

from fmi_helpers import native_model, rel  # noqa: E402

from postcapture.dynamics.build import build_system  # noqa: E402


@pytest.fixture
def fmu(envisat_fmu, tmp_path):
    md = fmpy.read_model_description(str(envisat_fmu.path))
    unzip = fmpy.extract(str(envisat_fmu.path), str(tmp_path / "unz"))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier)
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    state = [v.valueReference for v in md.modelVariables if v.name.startswith(("q[", "v["))]
    yield slave, vr, state
    slave.terminate()
    slave.freeInstance()


def _status(call):
    with pytest.raises(FMICallException) as err:
        call()
    return err.value.status


@pytest.mark.parametrize("h", [math.inf, math.nan, -0.1, 0.0, -1e-300, 1e8])
def test_bad_communication_steps_are_refused_and_the_state_kept(fmu, h):
    slave, vr, state = fmu
    slave.doStep(0.0, 0.1)
    before = slave.getReal(state)
    assert _status(lambda: slave.doStep(0.1, h)) == 3  # fmi2Error
    assert slave.getReal(state) == before
    slave.doStep(0.1, 0.1)  # a bad call does not break the instance
    assert slave.getRealStatus(2) == pytest.approx(0.2)  # fmi2LastSuccessfulTime


@pytest.mark.parametrize("H, h", [(0.01, 0.01), (0.06, 0.02), (0.1 / 3, 0.1 / 6), (0.3, None)])
def test_any_positive_step_in_equal_internal_steps(fmu, envisat, envisat_fmu, H, h):
    """A step H is ceil(H / step) equal internal steps (whole multiples: the configured step itself): the
    native process model given that internal step predicts the same state to 1e-12."""
    slave, vr, state = fmu
    for k in range(100):  # to t = 10 s, where the joint sines start
        slave.doStep(k * 0.1, 0.1)
    x = np.array(slave.getReal(state))
    slave.doStep(10.0, H)
    native = native_model(build_system(envisat), h or envisat_fmu.step, envisat_fmu.integrator)
    ref = native.predict(x, 10.0, H).x
    assert rel(slave.getReal(state), ref) <= 1e-12
    assert slave.getRealStatus(2) == 10.0 + H  # fmi2LastSuccessfulTime


def test_a_master_that_accumulates_time(fmu):
    """OMSimulator adds 0.1 a hundred times, then asks for the 1.95e-14 s left to reach 10 s: accepted."""
    slave, vr, state = fmu
    t = 0.0
    for _ in range(100):
        slave.doStep(t, 0.1)
        t += 0.1
    before = np.array(slave.getReal(state))
    assert 0.0 < 10.0 - t < 1e-13
    slave.doStep(t, 10.0 - t)
    assert slave.getRealStatus(2) == 10.0
    assert rel(slave.getReal(state), before) <= 1e-12


def test_jacobian_outputs_are_finite_and_flagged(fmu):
    """Outputs a master records every step: the Jacobians are 0 with jacobian_valid = 0 unless requested."""
    slave, vr, state = fmu
    jac = [vr["F[1,1]"], vr["G[4,1]"], vr["H[1,1]"], vr["Hp[1,1]"], vr["jacobian_valid"]]
    assert slave.getReal(jac) == [0.0] * 5
    slave.doStep(0.0, 0.1)
    assert slave.getReal(jac) == [0.0] * 5
    slave.setReal([vr["jacobian_request"]], [1.0])
    slave.doStep(0.1, 0.1)
    F11, G41, H11, Hp11, valid = slave.getReal(jac)
    assert valid == 1.0 and abs(F11 - 1.0) < 0.1 and G41 != 0.0
    slave.setReal([vr["jacobian_request"]], [0.0])
    slave.doStep(0.2, 0.1)
    assert slave.getReal(jac) == [0.0] * 5


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, 1e300])
def test_non_finite_and_huge_inputs_are_refused(fmu, value):
    slave, vr, state = fmu
    assert _status(lambda: slave.setReal([vr["force_x"]], [value])) == 3
    assert _status(lambda: slave.setReal([vr["x_corr[4]"]], [value])) == 3
    assert _status(lambda: slave.setReal([vr["target.I_xx"]], [value])) == 3
    assert slave.getReal([vr["force_x"]]) == [0.0]
    slave.doStep(0.0, 0.1)  # still usable


def test_non_physical_parameter_inputs_are_refused(fmu):
    slave, vr, state = fmu
    nominal = slave.getReal([vr["target.m"], vr["arm.stiffness_scale"]])
    assert _status(lambda: slave.setReal([vr["arm.stiffness_scale"]], [-0.5])) == 3
    assert _status(lambda: slave.setReal([vr["target.m"]], [0.0])) == 3
    assert slave.getReal([vr["target.m"], vr["arm.stiffness_scale"]]) == nominal
    slave.doStep(0.0, 0.1)


@pytest.mark.parametrize("quat", [(0.0, 0.0, 0.0, 0.0), (1e-9, 0.0, 0.0, 0.0), (0.5, 0.5, 0.5, 0.2)])
def test_bad_quaternion_in_the_correction_is_refused(fmu, quat):
    slave, vr, state = fmu
    x = np.array(slave.getReal(state))
    xc = x.copy()
    xc[3:7] = quat
    slave.setReal([vr[f"x_corr[{i + 1}]"] for i in range(x.size)] + [vr["reset"]], list(xc) + [1.0])
    assert _status(lambda: slave.doStep(0.0, 0.1)) == 3
    assert slave.getReal(state) == list(x)  # the saved state is untouched


def test_slightly_off_unit_quaternion_is_normalised(fmu):
    slave, vr, state = fmu
    x = np.array(slave.getReal(state))
    xc = x.copy()
    xc[3:7] *= 1.0 + 5e-7
    slave.setReal([vr[f"x_corr[{i + 1}]"] for i in range(x.size)] + [vr["reset"]], list(xc) + [1.0])
    slave.doStep(0.0, 0.1)
    q = np.array(slave.getReal(state))[3:7]
    assert abs(np.linalg.norm(q) - 1.0) < 1e-12


def test_failed_step_enters_the_error_state(fmu):
    """A diverging step (a huge rate on a stiff joint) fails; later calls report the error state."""
    slave, vr, state = fmu
    x = np.array(slave.getReal(state))
    xc = x.copy()
    xc[25 + 12] = 1e12  # an arm joint rate of 1e12 rad/s: Newton cannot converge at 0.1 s
    slave.setReal([vr[f"x_corr[{i + 1}]"] for i in range(x.size)] + [vr["reset"]], list(xc) + [1.0])
    assert _status(lambda: slave.doStep(0.0, 0.1)) == 3
    assert slave.getReal(state) == list(x)
    assert slave.getRealStatus(2) == 0.0  # fmi2LastSuccessfulTime
    assert _status(lambda: slave.doStep(0.0, 0.1)) == 3  # the error state, not "not in step mode"
    assert _status(lambda: slave.setReal([vr["force_x"]], [1.0])) == 3
    slave.reset()  # fmi2Reset leaves the error state
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.doStep(0.0, 0.1)
