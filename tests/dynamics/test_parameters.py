"""The named parameter vector: inertial-parameter algebra against Pinocchio, derivatives against finite differences."""

import numpy as np
import pinocchio as pin
import pinocchio_reference as ref
import pytest

from postcapture.core.errors import DomainError
from postcapture.dynamics.bodies import MassProperties
from postcapture.dynamics.build import build_system, initial_state
from lie_oracle import make_integrator
from postcapture.dynamics.parameters import (dmass_direction, dynamic_parameters, mass_properties, transform_matrix,
                                             with_target_mass)
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.process_model import NativeProcessModel


def _random_body(rng):
    A = rng.standard_normal((3, 3))
    return MassProperties(rng.uniform(1.0, 10.0), rng.standard_normal(3), A @ A.T + np.eye(3))


def test_dynamic_parameters_match_pinocchio(rng=np.random.default_rng(1)):
    body = _random_body(rng)
    pi = dynamic_parameters(body)
    np.testing.assert_allclose(pi, pin.Inertia(body.mass, body.com, body.inertia).toDynamicParameters(), rtol=1e-13)
    back = mass_properties(pi)
    np.testing.assert_allclose(back.com, body.com, rtol=1e-12)
    np.testing.assert_allclose(back.inertia, body.inertia, rtol=1e-12, atol=1e-12)


def test_transform_matrix_is_pinocchios_act(rng=np.random.default_rng(2)):
    body = _random_body(rng)
    X = pin.SE3.Random()
    inertia = pin.Inertia(body.mass, body.com, body.inertia)
    expected = X.act(inertia).toDynamicParameters()
    L = transform_matrix(X.rotation, X.translation)
    np.testing.assert_allclose(L @ inertia.toDynamicParameters(), expected, rtol=1e-12, atol=1e-12)


def test_mass_direction_is_the_derivative_at_fixed_com_and_inertia(rng=np.random.default_rng(3)):
    body = _random_body(rng)
    eps = 1e-4
    plus = dynamic_parameters(MassProperties(body.mass + eps, body.com, body.inertia))
    minus = dynamic_parameters(MassProperties(body.mass - eps, body.com, body.inertia))
    np.testing.assert_allclose(dmass_direction(dynamic_parameters(body)), (plus - minus) / (2 * eps), rtol=1e-8)


def test_the_hub_mass_moves_at_a_fixed_centre_of_mass_and_inertia(rng=np.random.default_rng(4)):
    """The engine's split (pc_target_mass, which the estimator FMU runs on its parameters in place) against the
    mass properties rebuilt with the new mass."""
    from postcapture.dynamics.engine import engine

    body = _random_body(rng)
    p = np.concatenate([dynamic_parameters(body), [1.0, 0.5]])
    got = with_target_mass(p, 2.5 * body.mass + 3.0, 3.0)
    want = dynamic_parameters(MassProperties(2.5 * body.mass, body.com, body.inertia))
    np.testing.assert_allclose(got[:10], want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    assert got[10:].tolist() == [1.0, 0.5]
    pi = np.ascontiguousarray(p[:10])
    engine().target_mass(pi, 2.5 * body.mass, pi)  # written over its input
    np.testing.assert_allclose(pi, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())
    with pytest.raises(ValueError, match="target_mass"):
        with_target_mass(p, 2.0, 3.0)


def test_names_and_nominal_values(envisat):
    system = build_system(envisat)
    names = system.parameter_names
    assert names[:10] == ("target.m", "target.mc_x", "target.mc_y", "target.mc_z", "target.I_xx", "target.I_xy",
                          "target.I_yy", "target.I_xz", "target.I_yz", "target.I_zz")
    assert names[10:] == ("chaser_wing.bending_scale", "chaser_wing.torsion_scale", "chaser_wing.damping_scale",
                          "envisat_wing.bending_scale", "envisat_wing.torsion_scale", "envisat_wing.damping_scale",
                          "arm.stiffness_scale", "arm.damping_scale")
    p = system.parameters()
    np.testing.assert_array_equal(p[10:], 1.0)
    # the hub plus the panels at rest reproduce the scenario's whole-target mass
    assert p[0] + system.layout.target_panel_mass == pytest.approx(envisat.target.mass, rel=1e-12)


def _fd_columns(system, f):
    """Fourth-order central differences of ``f()`` over every parameter (steps: 1 kg, 1 kg m, 10 kg m^2, 0.01 of a scale)."""
    p0 = system.parameters()

    def at(j, delta):
        p = p0.copy()
        p[j] += delta
        return f(system.with_parameters(p))

    cols = []
    for j in range(p0.size):
        eps = 1.0 if j < 4 else (10.0 if j < 10 else 1e-2)
        cols.append((-at(j, 2 * eps) + 8 * at(j, eps) - 8 * at(j, -eps) + at(j, -2 * eps)) / (12 * eps))
    return np.column_stack(cols)


def _excited_state(system, seconds=25.0):
    integ = make_integrator(system, "sdirk3")
    q, v = initial_state(system)
    for k in range(int(round(seconds / 0.1))):
        q, v = integ.step(q, v, 0.1 * k, 0.1)
    q[:3] = 0.0
    return q, v, seconds


def _column_errors(analytic, fd):
    scale = np.maximum(np.abs(fd).max(axis=0), 1e-300)
    return np.abs(analytic - fd).max(axis=0) / scale


def test_acceleration_derivatives(envisat):
    system = build_system(envisat)
    p0 = system.parameters()
    p0[13] += 40.0  # a hub CoM off T's origin, so that every inertial column is exercised
    p0[10:] = [1.1, 0.9, 1.3, 0.95, 1.05, 0.8, 1.2, 0.7]
    system = system.with_parameters(p0)
    q, v, t = _excited_state(system)
    ddq, _, _, Minv = ref.derivatives(system, q, v, t)
    analytic = ref.ddq_dparams(system, q, v, ddq, Minv)
    fd = _fd_columns(system, lambda s: ref.acceleration(s, q, v, t))
    assert np.all(_column_errors(analytic, fd) < 1e-6)
    assert np.abs(analytic).max(axis=0).min() > 0  # no parameter is invisible in this state


def test_step_and_measurement_derivatives(envisat):
    system = build_system(envisat)
    q, v, t = _excited_state(system)
    model = NativeProcessModel(system, 0.1, "sdirk3")
    model.set_newton(1e-15, 1e-15, 40)  # converged stages: FD without Newton noise
    x = np.concatenate([q, v])
    pred = model.predict(x, t, 0.1, jacobians=True)

    def step(perturbed):
        model.set_params(perturbed.parameters())
        p = model.predict(x, t, 0.1)
        return np.concatenate([model.local(p.x, pred.x), p.z])

    nominal = model.system
    fd = _fd_columns(nominal, step)
    model.set_params(nominal.parameters())
    n = model.n
    assert np.all(_column_errors(pred.G, fd[:n]) < 1e-6)
    # the measurement at the predicted state moves with the state and with the parameters
    assert np.all(_column_errors(pred.H @ pred.G + pred.Hp, fd[n:]) < 1e-6)
    # the mass shortcuts are the same derivative along d p / d m
    np.testing.assert_allclose(pred.g, pred.G @ model.system.dparams_dmass(), rtol=1e-12)


def test_filter_copy_does_not_touch_the_callers_system(envisat):
    system = build_system(envisat)
    before = system.joint_inertia(system.target_joint)
    model = NativeProcessModel(system, 0.1)
    p = model.params
    p[0] += 100.0
    p[-1] = 3.0
    model.set_params(p)
    np.testing.assert_array_equal(system.joint_inertia(system.target_joint), before)
    np.testing.assert_array_equal(system.parameters()[-1], 1.0)
    np.testing.assert_array_equal(model.system.parameters(), p)  # the model's description follows its instance
    with pytest.raises(AttributeError, match="immutable"):
        system.B = None


def test_copies_share_the_model_and_nothing_mutable(envisat):
    """A filter's copy runs its own instance over the same constant compiled model: parameters, input
    offset and warm start are its own, and a prediction does not depend on the other copy's history."""
    model = NativeProcessModel(build_system(envisat), 0.1)
    x = model.initial_state()
    other = model.copy()
    assert other.plant.model is model.plant.model and other.plant is not model.plant
    first = model.predict(x, 10.0, 0.1, jacobians=True)
    p = other.params
    p[-1] = 2.0
    other.set_params(p)
    other.plant.set_input_offset(np.full(other.plant.nu, 5.0))
    other.predict(x, 10.0, 0.1)
    assert model.params[-1] == 1.0
    again = model.predict(x, 10.0, 0.1, jacobians=True)
    np.testing.assert_array_equal(again.x, first.x)
    np.testing.assert_array_equal(again.F, first.F)
    third = other.copy()  # the copy takes the parameters, not the history
    np.testing.assert_array_equal(third.params, other.params)


@pytest.mark.parametrize("index,value,match", [(0, -5.0, "positive mass"), (4, -1e6, "positive definite"),
                                                 (15, -0.5, "scales >= 0"), (3, np.nan, "finite")])
def test_non_physical_parameters_are_refused(envisat, index, value, match):
    system = build_system(envisat)
    p = system.parameters()
    p[index] = value
    with pytest.raises(DomainError, match=match):
        system.with_parameters(p)
    with pytest.raises(DomainError, match=match):  # a filter's model refuses it too, naming it
        NativeProcessModel(system, 0.1).set_params(p)
    with pytest.raises(DomainError, match="parameter"):  # and so does the core, at its own boundary
        CompiledPlant(system).set_params(p)
