"""The compiled plant core against independent references: Pinocchio, central finite differences,
the Python Lie-group integrator (the oracle) and closed forms."""

import numpy as np
import pinocchio as pin
import pinocchio_reference as ref
import pytest
from lie_oracle import make_integrator

from postcapture.core.errors import CompileError
from postcapture.dynamics import compiled
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.integrators import TABLEAUX
from postcapture.dynamics.process_model import NativeProcessModel


@pytest.fixture(scope="module")
def system(envisat):
    return build_system(envisat)


@pytest.fixture(scope="module")
def plant(system):
    return CompiledPlant(system)


def _random_state(system, rng):
    """A generic state drawn from ``rng`` (Pinocchio's randomConfiguration has its own, unseeded)."""
    q = np.zeros(system.nq)
    q[:3] = rng.uniform(-1.0, 1.0, 3)
    quat = rng.standard_normal(4)
    q[3:7] = quat / np.linalg.norm(quat)
    q[7:] = rng.uniform(-0.5, 0.5, system.nq - 7)
    return q, rng.standard_normal(system.nv) * 0.1


def test_aba_rnea_mass_matrix_match_pinocchio(system, plant):
    rng = np.random.default_rng(1)
    model, data = ref.pin_data(system)
    for _ in range(5):
        q, v = _random_state(system, rng)
        tau = rng.standard_normal(system.nv) * 100.0
        a_ref = pin.aba(model, data, q, v, tau)
        np.testing.assert_allclose(plant.aba(q, v, tau), a_ref, rtol=0, atol=1e-10 * np.abs(a_ref).max())
        t_ref = pin.rnea(model, data, q, v, a_ref)
        np.testing.assert_allclose(plant.rnea(q, v, a_ref), t_ref, rtol=0, atol=1e-10 * np.abs(t_ref).max())
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(plant.mass_matrix(q), M, rtol=0, atol=1e-12 * np.abs(M).max())
        dq = rng.standard_normal(system.nv) * 0.2
        np.testing.assert_allclose(plant.integrate(q, dq), pin.integrate(model, q, dq), atol=1e-15)
        q1 = pin.integrate(model, q, dq)
        np.testing.assert_allclose(plant.difference(q, q1), pin.difference(model, q, q1), atol=1e-12)


def test_rnea_derivatives_match_pinocchio(system, plant):
    """The analytic inverse-dynamics partials (csrc/pc_rnea_derivatives.c) against Pinocchio's
    computeRNEADerivatives at generic states; the root's configuration columns are zero (no gravity)."""
    rng = np.random.default_rng(11)
    model, data = ref.pin_data(system)
    for _ in range(4):
        q, v = _random_state(system, rng)
        a = rng.standard_normal(system.nv)
        dq_ref, dv_ref, _ = (np.array(x) for x in pin.computeRNEADerivatives(model, data, q, v, a))
        dq, dv = plant.rnea_derivatives(q, v, a)
        np.testing.assert_allclose(dq, dq_ref, rtol=0, atol=1e-10 * np.abs(dq_ref).max())
        np.testing.assert_allclose(dv, dv_ref, rtol=0, atol=1e-10 * np.abs(dv_ref).max())
        assert np.abs(dq[:, :6]).max() <= 1e-10 * np.abs(dq_ref).max()


def test_energies_match_pinocchio(system, plant):
    """The kinetic and elastic energies a run records, against Pinocchio and the springs' closed form."""
    rng = np.random.default_rng(5)
    for _ in range(3):
        q, v = _random_state(system, rng)
        _, _, mech, _ = plant.sample(q, v, 0.0)
        assert mech[9] == pytest.approx(ref.kinetic_energy(system, q, v), rel=1e-12)
        assert mech[10] == pytest.approx(ref.elastic_energy(system, q), rel=1e-12)


def test_acceleration_partials_match_pinocchio(system, plant):
    rng = np.random.default_rng(2)
    for _ in range(3):
        q, v = _random_state(system, rng)
        u = rng.standard_normal(system.n_u)
        ddq, dq, dv, Minv = ref.derivatives_u(system, q, v, u)
        a, Aq, Av, Au, _ = plant.derivatives(q, v, u)
        np.testing.assert_allclose(a, ddq, atol=1e-10 * np.abs(ddq).max())
        np.testing.assert_allclose(Aq, dq, atol=1e-10 * np.abs(dq).max())
        np.testing.assert_allclose(Av, dv, atol=1e-10 * np.abs(dv).max())
        np.testing.assert_allclose(Au, Minv @ system.B, atol=1e-10 * np.abs(Minv).max())


def test_parameter_partials_against_the_regressor_and_finite_differences(system):
    """Parameter columns of d ddq / dp: against Pinocchio's body regressor (pinocchio_reference.ddq_dparams,
    an independent implementation) to 1e-7 of each column's scale, and against central differences of
    the core to 1e-3 of it (the random joint angles load the springs, so ddq is large and differences of
    it carry round-off; the step Jacobian's parameter columns are held to 1e-6 at a physical state)."""
    plant = CompiledPlant(system)
    rng = np.random.default_rng(3)
    q, v = _random_state(system, rng)
    u = rng.standard_normal(system.n_u)
    _, _, _, _, Ap = plant.derivatives(q, v, u)
    ddq, _, _, Minv = ref.derivatives_u(system, q, v, u)
    expected = ref.ddq_dparams(system, q, v, ddq, Minv)
    for k in range(plant.np):
        np.testing.assert_allclose(Ap[:, k], expected[:, k], rtol=0, atol=1e-7 * np.abs(expected[:, k]).max(),
                                   err_msg=plant.param_names[k])
    p0 = plant.params
    for k in range(plant.np):
        dp = 1e-3 * max(100.0, abs(p0[k]))
        pp, pm = p0.copy(), p0.copy()
        pp[k] += dp
        pm[k] -= dp
        plant.set_params(pp)
        ap = plant.acceleration(q, v, u)
        plant.set_params(pm)
        am = plant.acceleration(q, v, u)
        fd = (ap - am) / (2 * dp)
        np.testing.assert_allclose(Ap[:, k], fd, rtol=0, atol=1e-3 * np.abs(fd).max(), err_msg=plant.param_names[k])
    plant.set_params(p0)


def test_nominal_parameters_reproduce_the_model(system, plant):
    """Packing the target's inertia as T-frame parameters and back gives Pinocchio's joint inertia."""
    names = plant.param_names
    assert names[:10] == ("target.m", "target.mc_x", "target.mc_y", "target.mc_z", "target.I_xx", "target.I_xy",
                          "target.I_yy", "target.I_xz", "target.I_yz", "target.I_zz")
    assert tuple(names[-2:]) == ("arm.stiffness_scale", "arm.damping_scale")
    hub = system.layout.target_hub
    assert plant.params[0] == pytest.approx(hub.mass)
    np.testing.assert_allclose(plant.params[10:], 1.0)


@pytest.mark.parametrize("method", ["sdirk3", "sdirk4", "rk4"])
def test_step_matches_the_python_oracle(system, method):
    q, v = initial_state(system)
    h = 0.1 if method != "rk4" else 1e-3
    integ = make_integrator(system.copy(), method, newton_tol=1e-13, newton_atol=1e-16)
    plant = CompiledPlant(system, method)
    for k in range(5):
        t = 10.0 + k * h
        q_ref, v_ref = integ.step(q, v, t, h)
        q1, v1 = plant.step(q, v, t, h)
        np.testing.assert_allclose(q1, q_ref, atol=1e-11)
        np.testing.assert_allclose(v1, v_ref, atol=1e-11 * max(1.0, np.abs(v_ref).max()))
        q, v = q1, v1


def test_step_jacobian_against_central_differences(system):
    """State, input and parameter columns of the exact step Jacobian against central differences."""
    plant = CompiledPlant(system)
    plant.set_newton(1e-14, 1e-16, 30)
    q, v = initial_state(system)
    for k in range(3):
        q, v = plant.step(q, v, 10.0 + 0.1 * k, 0.1)
    t, h = 10.3, 0.1
    _, _, F, Fu, Fp = plant.step_jacobian(q, v, t, h)
    nv = system.nv

    def step(dx=None, du=None, p=None):
        qq = pin.integrate(ref.pin_data(system)[0], q, dx[:nv]) if dx is not None else q
        vv = v + dx[nv:] if dx is not None else v
        plant.set_input_offset(du)
        if p is not None:
            plant.set_params(p)
        q1, v1 = plant.step(qq, vv, t, h)
        plant.set_input_offset(None)
        return q1, v1

    def diff(a, b):
        return np.concatenate([pin.difference(ref.pin_data(system)[0], b[0], a[0]), a[1] - b[1]])

    rng = np.random.default_rng(4)
    for col in rng.choice(2 * nv, 8, replace=False):
        e = np.zeros(2 * nv)
        e[col] = 1e-6
        fd = diff(step(dx=e), step(dx=-e)) / 2e-6
        np.testing.assert_allclose(F[:, col], fd, atol=1e-6 * max(1.0, np.abs(F[:, col]).max()))
    for col in (0, 5, 8):
        e = np.zeros(system.n_u)
        e[col] = 1e-3
        fd = diff(step(du=e), step(du=-e)) / 2e-3
        np.testing.assert_allclose(Fu[:, col], fd, atol=1e-6 * max(1.0, np.abs(Fu[:, col]).max()))
    p0 = plant.params
    for col in range(plant.np):
        d = 1e-6 * max(1.0, abs(p0[col]))
        pp, pm = p0.copy(), p0.copy()
        pp[col] += d
        pm[col] -= d
        fd = diff(step(p=pp), step(p=pm)) / (2 * d)
        plant.set_params(p0)
        np.testing.assert_allclose(Fp[:, col], fd, atol=1e-6 * max(1.0, np.abs(Fp[:, col]).max()),
                                   err_msg=plant.param_names[col])


def test_prediction_matches_the_python_oracle(system):
    model = NativeProcessModel(system, 0.1)
    x = model.initial_state()
    for k in range(3):
        x = model.predict(x, 10.0 + 0.1 * k, 0.1).x
    pred = model.predict(x, 10.3, 0.1, jacobians=True)
    integ = make_integrator(system.copy(), "sdirk3", newton_tol=1e-13, newton_atol=1e-16)
    ref = integ.step_jacobian(x[: system.nq], x[system.nq :], 10.3, 0.1)
    np.testing.assert_allclose(pred.x, np.concatenate([ref.q, ref.v]), atol=1e-11)
    np.testing.assert_allclose(pred.F, ref.Fx, atol=1e-9 * np.abs(ref.Fx).max())
    np.testing.assert_allclose(pred.g, ref.Fm, atol=1e-9 * np.abs(ref.Fm).max())


def test_a_frozen_prediction_chains_its_first_step(system, plant):
    """``frozen``: the state takes every step (bit for bit the plain prediction's), the Jacobians are the
    first step's composed n times, computed here from a one-step prediction with numpy; and they stay close to
    the exact ones over a 0.1 s cycle of four SDIRK4 steps (the filters' default)."""
    model = NativeProcessModel(system, 0.025, "sdirk4")
    x = model.initial_state()
    for k in range(20):
        x = model.predict(x, 0.1 * k, 0.1).x
    q, v, t, h = x[: system.nq], x[system.nq :], 2.0, 0.025
    plain = plant.predict(q, v, t, h, 4, False)
    frozen = plant.predict(q, v, t, h, 4, True, frozen=True)
    exact = plant.predict(q, v, t, h, 4, True)
    one = plant.predict(q, v, t, h, 1, True)
    for a, b in zip(plain[:3], frozen[:3]):
        assert np.array_equal(a, b)
    F1, Fp1 = one[3], one[5]
    F = np.linalg.matrix_power(F1, 4)
    Fp = sum(np.linalg.matrix_power(F1, k) for k in range(4)) @ Fp1
    np.testing.assert_allclose(frozen[3], F, rtol=0, atol=1e-12 * np.abs(F).max())
    np.testing.assert_allclose(frozen[5], Fp, rtol=0, atol=1e-12 * np.abs(Fp).max())
    assert np.linalg.norm(frozen[3] - exact[3]) <= 1e-4 * np.linalg.norm(exact[3])
    assert np.linalg.norm(frozen[5] - exact[5]) <= 0.2 * np.linalg.norm(exact[5])


def test_mass_setter_moves_only_the_hub_mass(system):
    model = NativeProcessModel(system, 0.1)
    p0 = model.params
    model.mass = model.mass + 50.0
    dp = model.params - p0
    assert dp[0] == pytest.approx(50.0)
    np.testing.assert_allclose(dp[10:], 0.0)


def test_sdirk4_tableau_conditions():
    t = TABLEAUX["sdirk4"]
    np.testing.assert_allclose(t.A.sum(axis=1), t.c, atol=1e-15)
    for k, rhs in ((0, 1.0), (1, 0.5), (2, 1 / 3), (3, 0.25)):
        assert t.b @ t.c**k == pytest.approx(rhs, abs=1e-14)
    assert t.b @ (t.A @ t.c) == pytest.approx(1 / 6, abs=1e-14)


def test_missing_compiler_is_one_clear_error(monkeypatch, tmp_path):
    monkeypatch.setenv("CC", "/nonexistent/cc")
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(CompileError, match="C compiler"):
        compiled.compiler()


def test_unwritable_cache_is_one_clear_error(monkeypatch, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(CompileError, match="POSTCAPTURE_CACHE"):
        compiled._build(compiled.compiler(), compiled.source_files(), blocker / "sub" / "core.so")


def test_compiler_error_names_the_cause(tmp_path):
    files = dict(compiled.source_files())
    files["pc_model.c"] += "\nthis is not C;\n"
    with pytest.raises(CompileError, match="failed"):
        compiled._build(compiled.compiler(), files, tmp_path / "core.so")


def test_spong_rotors_dense_newton_and_jacobian(envisat):
    """Springs coupling a rotor and its link (the dense Newton matrix path): steps and step Jacobian
    against the oracle."""
    data = envisat.model_dump()
    for j in data["arm"]["joints"]:
        j["rotor_inertia"] = 0.5
    from postcapture.config.schema import Scenario

    system = build_system(Scenario.model_validate(data))
    q, v = initial_state(system)
    plant = CompiledPlant(system)
    plant.set_newton(1e-13, 1e-16, 40)
    integ = make_integrator(system.copy(), "sdirk3", newton_tol=1e-13, newton_atol=1e-16)
    for k in range(3):
        t = 12.0 + 0.05 * k
        ref = integ.step_jacobian(q, v, t, 0.05)
        q1, v1, F, Fu, _ = plant.step_jacobian(q, v, t, 0.05)
        np.testing.assert_allclose(q1, ref.q, atol=1e-11)
        np.testing.assert_allclose(v1, ref.v, atol=1e-10 * max(1.0, np.abs(ref.v).max()))
        np.testing.assert_allclose(F, ref.Fx, atol=1e-8 * np.abs(ref.Fx).max())
        np.testing.assert_allclose(Fu, ref.Fu, atol=1e-8 * np.abs(ref.Fu).max())
        q, v = q1, v1


def test_a_run_cut_into_chunks_is_the_same_run(system):
    """Times never accumulate: the chunked run (progress reports) computes the same step times."""
    from postcapture.dynamics.simulate import simulate_system

    q0, v0 = initial_state(system)
    whole = simulate_system(system, q0, v0, 30.0, step=0.025, sample_period=0.1, integrator="sdirk4")
    chunks = simulate_system(system, q0, v0, 30.0, step=0.025, sample_period=0.1, integrator="sdirk4",
                             progress=lambda fraction: None)
    np.testing.assert_array_equal(whole.q, chunks.q)
    np.testing.assert_array_equal(whole["accel_B"], chunks["accel_B"])


def test_a_tolerance_sets_the_truth_step(envisat):
    """By default the truth's accuracy chooses its SDIRK4 step, which divides the sample period and meets the
    declared rate tolerance against a run at half that step (an independent check of the pilot's estimate);
    an explicit step is taken as given."""
    from postcapture.core import rotations as rot
    from postcapture.dynamics.simulate import simulate

    traj = simulate(envisat, duration=30.0)
    assert traj.attrs["integrator"] == "sdirk4"
    h = traj.attrs["step_s"]
    ratio = envisat.simulation.sample_period / h
    assert ratio == round(ratio) and ratio >= 2
    finer = simulate(envisat, duration=30.0, step=h / 2)
    mean_rate = lambda tr: rot.box_minus(tr["q_BN"][:, 1:], tr["q_BN"][:, :-1]) / 0.1  # noqa: E731
    # Richardson: the error at h is (difference to h/2) * 16/15 for an order-4 method; over 30 s of the 300 s
    assert np.abs(mean_rate(traj) - mean_rate(finer)).max() * 16 / 15 <= envisat.simulation.rate_tolerance
    plain = simulate(envisat.with_updates(simulation={**envisat.simulation.model_dump(), "step": 0.05,
                                                      "integrator": "sdirk3"}), duration=2.0)
    assert plain.attrs["integrator"] == "sdirk3" and plain.attrs["step_s"] == 0.05
