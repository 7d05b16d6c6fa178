"""FMUProcessModel against NativeProcessModel: state, measurement and Jacobians (x, z, F, g, H, h, G, Hp),
and what the filters read besides attitude and rate (velocity, arm angles, accelerometer, parameters)."""

import numpy as np
import pytest

import fmpy  # noqa: F401 - the fmi extra is part of the test install

from fmi_helpers import rel, native_model  # noqa: E402
from tiny_fmu import I1, I3, build_tiny_fmu  # noqa: E402

from postcapture.core.errors import FMIError  # noqa: E402
from postcapture.core.rotations import compose, exp_map  # noqa: E402
from postcapture.dynamics.build import build_system  # noqa: E402
from postcapture.dynamics.process_model import NativeProcessModel  # noqa: E402
from postcapture.estimation.process import ProcessModel  # noqa: E402
from postcapture.fmi import FMUProcessModel  # noqa: E402


@pytest.fixture(scope="module")
def flexible(envisat):
    return build_system(envisat)


@pytest.fixture(scope="module")
def native(flexible, envisat):
    """The native process model with the FMU's integrator and internal step (the scenario's)."""
    return lambda: native_model(flexible, envisat.estimation.model_step, envisat.estimation.integrator)


@pytest.fixture(scope="module")
def state_at_20s(native):
    pm = native()
    x = pm.initial_state()
    for k in range(200):
        x = pm.predict(x, k * 0.1, 0.1).x
    return x


@pytest.fixture
def fmu_model(envisat_fmu):
    with FMUProcessModel(envisat_fmu.path) as model:
        yield model


def test_protocol_and_conventions(fmu_model, native):
    native = native()
    assert isinstance(fmu_model, ProcessModel)
    assert (fmu_model.nx, fmu_model.n, fmu_model.n_meas) == (native.nx, native.n, native.n_meas)
    assert (
        fmu_model.tangent_attitude == native.tangent_attitude
        and fmu_model.tangent_rate == native.tangent_rate
    )
    assert fmu_model.mass == native.mass
    x0 = fmu_model.initial_state()
    np.testing.assert_array_equal(x0, native.initial_state())
    rng = np.random.default_rng(11)
    dx = 0.1 * rng.standard_normal(native.n)
    np.testing.assert_allclose(fmu_model.retract(x0, dx), native.retract(x0, dx), rtol=0, atol=1e-15)
    x1 = native.retract(x0, dx)
    np.testing.assert_allclose(fmu_model.local(x1, x0), native.local(x1, x0), rtol=0, atol=1e-14)
    np.testing.assert_array_equal(fmu_model.attitude(x1), native.attitude(x1))
    np.testing.assert_array_equal(fmu_model.body_rate(x1), native.body_rate(x1))
    np.testing.assert_array_equal(fmu_model.chaser_velocity(x1), native.chaser_velocity(x1))
    np.testing.assert_array_equal(fmu_model.chaser_position(x1), native.chaser_position(x1))
    np.testing.assert_array_equal(fmu_model.arm_angles(x1), native.arm_angles(x1))
    assert fmu_model.tangent_velocity == native.tangent_velocity
    np.testing.assert_array_equal(fmu_model.tangent_arm, native.tangent_arm)
    np.testing.assert_array_equal(fmu_model.accelerometer_position, native.accelerometer_position)
    assert fmu_model.param_names == native.param_names
    np.testing.assert_array_equal(fmu_model.params, native.params)
    assert fmu_model.jacobian_method == "outputs"
    assert fmu_model.missing("joint", native.param_names) == [] and fmu_model.missing("reference_dual") == []


@pytest.mark.parametrize("t, dt", [(20.0, 0.1), (20.1, 0.3), (45.0, 0.1)])
def test_predict_matches_native(fmu_model, native, state_at_20s, t, dt):
    """Jacobian outputs: x, z, F, g, H, h, G, Hp to 1e-12 of the native ones, both with default settings.

    The FMU compiles the native process model's core (same integrator, Newton policy, warm start and
    step rule), so only round-off separates them.
    """
    native = native()
    ref = native.predict(state_at_20s, t, dt, jacobians=True)
    got = fmu_model.predict(state_at_20s, t, dt, jacobians=True)
    for name in ("x", "z", "F", "g", "H", "h", "G", "Hp"):
        assert rel(getattr(got, name), getattr(ref, name)) <= 1e-12, name
    plain = fmu_model.predict(state_at_20s, t, dt)
    np.testing.assert_array_equal(plain.x, got.x)
    assert plain.F is None


def test_mass_and_parameters(fmu_model, native, state_at_20s):
    """The mass moves the hub's parameter inputs as the native model moves its parameters; any parameter
    vector goes in as inputs."""
    native = native()
    native.mass = fmu_model.mass = 6000.0
    np.testing.assert_array_equal(fmu_model.params, native.params)
    ref = native.predict(state_at_20s, 30.0, 0.1, jacobians=True)
    got = fmu_model.predict(state_at_20s, 30.0, 0.1, jacobians=True)
    for name in ("x", "z", "F", "g", "H", "h", "G", "Hp"):
        assert rel(getattr(got, name), getattr(ref, name)) <= 1e-12, name
    p = native.params * np.r_[np.ones(10), np.linspace(0.8, 1.2, native.params.size - 10)]
    native.set_params(p)
    fmu_model.set_params(p)
    ref = native.predict(state_at_20s, 30.0, 0.1, jacobians=True)
    got = fmu_model.predict(state_at_20s, 30.0, 0.1, jacobians=True)
    for name in ("x", "F", "G"):
        assert rel(getattr(got, name), getattr(ref, name)) <= 1e-12, name


def test_directional_derivative_path(envisat_fmu, native, state_at_20s):
    """Continuous partials discretised with expm: H and Hp exact (the parameter inputs are standard
    knowns), h through Hp, F and G approximate.

    F is first order in dt: the attitude and rate block within 1e-2; the stiff joint modes are damped
    differently by the implicit integrator.
    """
    native = native()
    ref = native.predict(state_at_20s, 20.0, 0.1, jacobians=True)
    with FMUProcessModel(envisat_fmu.path, jacobians="directional") as model:
        assert model.jacobian_method == "directional"
        got = model.predict(state_at_20s, 20.0, 0.1, jacobians=True)
    assert rel(got.x, ref.x) <= 1e-12
    assert rel(got.H, ref.H) <= 1e-8
    assert rel(got.Hp, ref.Hp) <= 1e-8
    assert rel(got.h, ref.h) <= 1e-8
    rows = np.r_[3:6, 28:31]
    assert rel(got.F[np.ix_(rows, rows)], ref.F[np.ix_(rows, rows)]) <= 1e-2
    assert rel(got.G[rows], ref.G[rows]) <= 0.1


def test_finite_differences_without_directional_derivatives(envisat, rigid_plain_fmu):
    """The FMU exported without directional derivatives nor Jacobian outputs still gives F, g, H, h."""
    system = build_system(envisat, "rigid")
    native = native_model(system, envisat.estimation.model_step, envisat.estimation.integrator)
    x = native.initial_state()
    for k in range(250):
        x = native.predict(x, k * 0.1, 0.1).x
    ref = native.predict(x, 25.0, 0.1, jacobians=True)
    with FMUProcessModel(rigid_plain_fmu.path) as model:
        assert model.jacobian_method == "finite_differences"
        got = model.predict(x, 25.0, 0.1, jacobians=True)
        again = model.predict(got.x, 25.1, 0.1)  # the FMU is left at the nominal step's end
    assert rel(got.x, ref.x) <= 1e-12 and rel(got.z, ref.z) <= 1e-10
    assert rel(got.F, ref.F) <= 1e-6
    assert rel(got.g, ref.g) <= 1e-4
    assert rel(got.H, ref.H) <= 1e-6
    assert rel(got.h, ref.h) <= 1e-4
    assert rel(got.G, ref.G) <= 1e-3 and rel(got.Hp, ref.Hp) <= 1e-3  # steps of 1e-4 of each parameter
    assert rel(again.x, native.predict(ref.x, 25.1, 0.1).x) <= 1e-12


def _axisymmetric(x0, t):
    """Torque-free axisymmetric body (I1 = I2): closed-form omega and q_BN at time t."""
    w0 = x0[4:7]
    lam = (I3 - I1) / I1 * w0[2]
    c, s = np.cos(lam * t), np.sin(lam * t)
    w = np.array([w0[0] * c - w0[1] * s, w0[0] * s + w0[1] * c, w0[2]])
    # q(t) = q0 exp(H_B0 t / I1) exp(-lam t e3) with H_B0 the body momentum at t = 0
    Hb = np.array([I1 * w0[0], I1 * w0[1], I3 * w0[2]])
    q = compose(exp_map(-lam * t * np.array([0.0, 0.0, 1.0])), compose(exp_map(Hb * t / I1), x0[:4]))
    return np.concatenate([q, w])


def test_generic_quaternion_fmu(tiny_dir):
    """A hand-written FMU (not ours) with quaternion kinematics against the closed form.

    The prediction is checked against the closed form, the finite-difference Jacobian against a direct
    perturbation of the closed form.
    """
    path = build_tiny_fmu(tiny_dir, "ok")
    with FMUProcessModel(path) as model:
        assert (model.nx, model.n, model.n_meas) == (7, 6, 3)
        assert model.tangent_attitude == slice(0, 3) and model.tangent_rate == slice(3, 6)
        x0 = model.initial_state()
        p = model.predict(x0, 0.0, 2.0, jacobians=True)
        assert model.jacobian_method == "finite_differences"
        # no position in a quaternion state: the recommended schemes cannot take the orbit's field out
        assert not any("chaser's position" in m for m in model.missing("dual"))
        assert any("chaser's position" in m for m in model.missing("dual", orbit=True))
        assert not any("chaser's position" in m for m in model.missing("reference_dual", orbit=True))
        with pytest.raises(FMIError, match="free_flyer"):
            model.chaser_position(x0)
    truth = _axisymmetric(x0, 2.0)
    assert np.abs(p.x - truth).max() <= 1e-10
    eps = 1e-7
    for j in range(6):
        d = np.zeros(6)
        d[j] = eps
        col = model.local(_axisymmetric(model.retract(x0, d), 2.0), truth) / eps
        np.testing.assert_allclose(p.F[:, j], col, atol=5e-6)


def test_fmi3_fmu(tiny_dir):
    """The same hand-written plant as an FMI 3.0 co-simulation FMU runs through the FMI 3 calls."""
    from tiny_fmu import build_tiny_fmu3

    path = build_tiny_fmu3(tiny_dir)
    with FMUProcessModel(path) as model:
        assert model.capabilities["fmi_version"] == "3.0"
        x0 = model.initial_state()
        p = model.predict(x0, 0.0, 2.0, jacobians=True)
    assert np.abs(p.x - _axisymmetric(x0, 2.0)).max() <= 1e-10
    assert p.F.shape == (6, 6) and np.isfinite(p.F).all()


def test_plant_in_the_filters_orbit(envisat_dict, tmp_path):
    """With ``[orbit] filters = "model"`` the exported plant feels the gravity gradient as the filters' native
    model does (the same core: states and Jacobians to 1e-12), the field changes a step, and the accelerations
    list the root's pose among their dependencies: a step's velocities change with the position alone."""
    import fmpy

    from postcapture.config import scenario_from_dict
    from postcapture.fmi import export_fmu

    envisat_dict["orbit"]["filters"] = "model"
    envisat_dict["estimation"]["jacobian"] = "every_step"  # what the FMU's Jacobian outputs are
    sc = scenario_from_dict(envisat_dict)
    report = export_fmu(sc, tmp_path / "orbit.fmu", variant="rigid")
    native = NativeProcessModel.for_filters(sc, variant="rigid")
    x = native.initial_state()
    for k in range(50):
        x = native.predict(x, k * 0.1, 0.1).x
    ref = native.predict(x, 5.0, 0.1, jacobians=True)
    envisat_dict["orbit"]["filters"] = "cover"
    free = NativeProcessModel.for_filters(scenario_from_dict(envisat_dict), variant="rigid").predict(x, 5.0, 0.1)
    assert rel(free.x, ref.x) > 1e-9  # the field matters over one step
    dx = np.zeros(native.n)
    dx[0:3] = 10.0  # m: the chaser's origin moved in its body frame, nothing else
    shifted = native.retract(x, dx)
    vel = slice(native.nq, native.nx)
    with FMUProcessModel(report.path) as model:
        got = model.predict(x, 5.0, 0.1, jacobians=True)
        moved = model.predict(shifted, 5.0, 0.1).x
    assert rel(got.x, ref.x) <= 1e-12
    for name in ("F", "G", "H", "Hp"):
        assert rel(getattr(got, name), getattr(ref, name)) <= 1e-12, name
    assert rel(moved, native.predict(shifted, 5.0, 0.1).x) <= 1e-12
    assert np.abs(moved[vel] - got.x[vel]).max() > 1e3 * np.finfo(float).eps * np.abs(got.x[vel]).max()
    with FMUProcessModel(report.path, jacobians="directional") as model:
        got = model.predict(x, 5.0, 0.1, jacobians=True)
    assert rel(got.H, ref.H) <= 1e-8 and rel(got.Hp, ref.Hp) <= 1e-8
    rows = np.r_[native.tangent_attitude, native.tangent_rate]
    assert rel(got.F[np.ix_(rows, rows)], ref.F[np.ix_(rows, rows)]) <= 1e-2
    md = fmpy.read_model_description(str(report.path))
    deps = {u.variable.name: {d.name for d in u.dependencies} for u in md.outputs}
    assert {"q[1]", "q[2]", "q[3]", "q[4]", "q[7]"} <= deps["accel_B_x"]
