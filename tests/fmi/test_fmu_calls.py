"""Bad calls on the exported FMU: each is refused with fmi2Error and a logged message naming the
variable, the state is kept, and a failed step leaves the instance in the error state."""

import math

import numpy as np
import pytest

import fmpy
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave


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


@pytest.mark.parametrize("h", [math.inf, math.nan, -0.1, 0.0, 1e8, 0.05 + 1e-4])
def test_bad_communication_steps_are_refused_and_the_state_kept(fmu, h):
    slave, vr, state = fmu
    slave.doStep(0.0, 0.1)
    before = slave.getReal(state)
    assert _status(lambda: slave.doStep(0.1, h)) == 3  # fmi2Error
    assert slave.getReal(state) == before
    slave.doStep(0.1, 0.1)  # a bad call does not break the instance
    assert slave.getRealStatus(2) == pytest.approx(0.2)  # fmi2LastSuccessfulTime


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, 1e300])
def test_non_finite_and_huge_inputs_are_refused(fmu, value):
    slave, vr, state = fmu
    assert _status(lambda: slave.setReal([vr["force_x"]], [value])) == 3
    assert _status(lambda: slave.setReal([vr["x_corr[4]"]], [value])) == 3
    assert slave.getReal([vr["force_x"]]) == [0.0]
    slave.doStep(0.0, 0.1)  # still usable


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
