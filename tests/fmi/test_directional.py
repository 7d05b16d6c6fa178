"""fmi2GetDirectionalDerivative against central finite differences of the FMU's own outputs.

Knowns: the states (set at the same time through a re-initialisation, where states with
``initial="exact"`` may be set), the force inputs and the parameter inputs (set in step mode); unknowns:
the state derivatives and the named outputs.
"""

import numpy as np
import pytest

import fmpy

from fmpy.fmi2 import FMU2Slave  # noqa: E402

T = 15.0  # s: joint sines on, thrusters off


@pytest.fixture(scope="module")
def setup(envisat_fmu, tmp_path_factory):
    md = fmpy.read_model_description(str(envisat_fmu.path))
    unzip = fmpy.extract(str(envisat_fmu.path), str(tmp_path_factory.mktemp("dd")))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    for k in range(int(round(T / 0.1))):
        fmu.doStep(k * 0.1, 0.1)
    vars_ = md.modelVariables
    states = [v.valueReference for v in vars_ if v.name.startswith(("q[", "v["))]
    params = [v.valueReference for v in vars_ if v.causality == "input" and "." in v.name]
    inputs = [v.valueReference for v in vars_ if v.causality == "input" and v.variability == "continuous"
              and v.valueReference not in params]
    unknowns = [v.valueReference for v in vars_ if v.name.startswith("der(")] + [
        v.valueReference
        for v in vars_
        if v.causality == "output" and v.variability == "continuous" and not v.name.startswith(("q[", "v["))
    ]
    x = np.array(fmu.getReal(states))
    fmu.params = params
    yield fmu, states, inputs, unknowns, x
    fmu.terminate()
    fmu.freeInstance()


def _outputs_at(fmu, states, unknowns, x):
    """Unknowns at state ``x`` and time ``T`` through a re-initialisation."""
    fmu.reset()
    fmu.setupExperiment(startTime=T)
    fmu.enterInitializationMode()
    fmu.setReal(states, list(x))
    fmu.exitInitializationMode()
    return np.array(fmu.getReal(unknowns))


def _check(J_dd, J_fd, labels, atol=0.0):
    """Each column to 1e-6 of its largest entry (plus ``atol``, the differences' round-off)."""
    for j in range(J_fd.shape[1]):
        scale = np.abs(J_fd[:, j]).max()
        err = np.abs(J_dd[:, j] - J_fd[:, j]).max()
        if scale == 0.0:
            assert err <= 1e-12 + atol, labels[j]
        else:
            assert err <= 1e-6 * scale + atol, (labels[j], err / scale)


def test_state_columns(setup):
    fmu, states, _inputs, unknowns, x = setup
    base = _outputs_at(fmu, states, unknowns, x)
    J_dd = np.array(
        [
            fmu.getDirectionalDerivative(unknowns, states, list(np.eye(len(states))[j]))
            for j in range(len(states))
        ]
    ).T
    J_fd = np.zeros_like(J_dd)
    for j in range(len(states)):
        eps = 1e-6 * max(1.0, abs(x[j]))
        xp, xm = x.copy(), x.copy()
        xp[j] += eps
        xm[j] -= eps
        J_fd[:, j] = (_outputs_at(fmu, states, unknowns, xp) - _outputs_at(fmu, states, unknowns, xm)) / (
            2 * eps
        )
    _check(J_dd, J_fd, [f"state {j}" for j in range(len(states))])
    np.testing.assert_array_equal(_outputs_at(fmu, states, unknowns, x), base)


def test_input_columns(setup):
    fmu, states, inputs, unknowns, x = setup
    _outputs_at(fmu, states, unknowns, x)  # back to step mode at (x, T)
    J_dd = np.array(
        [
            fmu.getDirectionalDerivative(unknowns, inputs, list(np.eye(len(inputs))[j]))
            for j in range(len(inputs))
        ]
    ).T
    J_fd = np.zeros_like(J_dd)
    for j, vr in enumerate(inputs):
        vals = []
        for du in (1e-3, -1e-3):
            fmu.setReal([vr], [du])
            vals.append(np.array(fmu.getReal(unknowns)))
        fmu.setReal([vr], [0.0])
        J_fd[:, j] = (vals[0] - vals[1]) / 2e-3
    _check(J_dd, J_fd, [f"input {j}" for j in range(len(inputs))])


def test_parameter_columns(setup):
    """The parameter vector's inputs are knowns like any input: the partials the recommended filters need."""
    fmu, states, _inputs, unknowns, x = setup
    _outputs_at(fmu, states, unknowns, x)
    params = fmu.params
    assert len(params) == 18
    p0 = np.array(fmu.getReal(params))
    J_dd = np.array(
        [fmu.getDirectionalDerivative(unknowns, params, list(np.eye(len(params))[j])) for j in range(len(params))]
    ).T
    J_fd = np.zeros_like(J_dd)
    for j, vr in enumerate(params):
        dp = 1e-5 * max(abs(p0[j]), 1.0)
        vals = []
        for sign in (1.0, -1.0):
            fmu.setReal([vr], [p0[j] + sign * dp])
            vals.append(np.array(fmu.getReal(unknowns)))
        fmu.setReal([vr], [p0[j]])
        J_fd[:, j] = (vals[0] - vals[1]) / (2 * dp)
    assert np.abs(J_dd).max() > 0.0
    # outputs of order 1 differenced over 2e-5 leave about 1e-11 of round-off
    _check(J_dd, J_fd, [f"parameter {j}" for j in range(len(params))], atol=1e-9)


def test_directional_derivative_errors(setup):
    fmu, states, _inputs, unknowns, _x = setup
    with pytest.raises(fmpy.fmi1.FMICallException):
        fmu.getDirectionalDerivative(unknowns[:1], [10**6], [1.0])  # not a state or input


def test_switched_off_in_the_plain_export(rigid_plain_fmu, tmp_path):
    md = fmpy.read_model_description(str(rigid_plain_fmu.path))
    unzip = fmpy.extract(str(rigid_plain_fmu.path), str(tmp_path / "plain"))
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzip, modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    vr = {v.name: v.valueReference for v in md.modelVariables}
    with pytest.raises(fmpy.fmi1.FMICallException, match="fmi2GetDirectionalDerivative"):
        fmu.getDirectionalDerivative([vr["der(v[1])"]], [vr["v[1]"]], [1.0])
    fmu.terminate()
    fmu.freeInstance()


def test_declared_dependencies_cover_every_nonzero_partial(setup, envisat_fmu):
    """ModelStructure's dependencies (what masters build their graphs from) against the partials: a known
    an unknown does not list has a zero partial (at a state where the joint sines are on)."""
    fmu, states, inputs, unknowns, x = setup
    _outputs_at(fmu, states, unknowns, x)
    md = fmpy.read_model_description(str(envisat_fmu.path))
    known = states + inputs + fmu.params
    by_vr = {v.valueReference: v for v in md.modelVariables}
    listed = {u.variable.valueReference: {d.valueReference for d in u.dependencies}
              for u in list(md.outputs) + list(md.derivatives)}
    J = np.array([fmu.getDirectionalDerivative(unknowns, known, list(np.eye(len(known))[j]))
                  for j in range(len(known))]).T
    undeclared = [(by_vr[u].name, by_vr[k].name) for i, u in enumerate(unknowns) for j, k in enumerate(known)
                  if J[i, j] != 0.0 and k not in listed[u]]
    assert undeclared == []
    assert sum(len(listed[u]) for u in unknowns) < 0.6 * len(unknowns) * len(known)  # and they are selective


def test_the_sampled_sensors_partials(envisat_fmu, tmp_path):
    """``gyro_mean_*`` and ``accel_mean_*`` (discrete): before the first step they are the body rate and the
    acceleration (free space: no tidal field), with those partials; after a step they are fixed, partials 0."""
    md = fmpy.read_model_description(str(envisat_fmu.path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=fmpy.extract(str(envisat_fmu.path), str(tmp_path)),
                    modelIdentifier=md.coSimulation.modelIdentifier)
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    states = [v.valueReference for v in md.modelVariables if v.name.startswith(("q[", "v["))]
    now = [vr[f"omega_BN_B_{a}"] for a in "xyz"] + [vr[f"accel_B_{a}"] for a in "xyz"]
    sensed = [vr[f"gyro_mean_{a}"] for a in "xyz"] + [vr[f"accel_mean_{a}"] for a in "xyz"]

    def jacobian(unknowns):
        return np.array([fmu.getDirectionalDerivative(unknowns, states, list(np.eye(len(states))[j]))
                         for j in range(len(states))]).T

    assert np.array_equal(fmu.getReal(sensed), fmu.getReal(now))
    before = jacobian(sensed)
    assert np.abs(before).max() > 0.0 and np.array_equal(before, jacobian(now))
    fmu.doStep(0.0, 0.1)
    assert not jacobian(sensed).any()
    fmu.terminate()
    fmu.freeInstance()
