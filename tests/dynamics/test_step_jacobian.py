"""The exact step Jacobian agrees with central finite differences (state, inputs, target mass)."""

import numpy as np
import pinocchio_reference as ref
import pytest

from postcapture.dynamics.build import build_system, initial_state
from lie_oracle import make_integrator


def _state_after(system, integ, seconds):
    q, v = initial_state(system)
    h = 0.05
    for k in range(int(round(seconds / h))):
        q, v = integ.step(q, v, k * h, h)
    q[:3] = 0.0  # translation invariance: small positions keep finite differences clear of round-off
    return q, v, seconds


def fd4(f, x0, eps):
    """Fourth-order central difference of f at x0."""
    return (-f(x0 + 2 * eps) + 8 * f(x0 + eps) - 8 * f(x0 - eps) + f(x0 - 2 * eps)) / (12 * eps)


def _fd_jacobian(system, integ, q, v, t, h, eps_x=1e-6, eps_m=5.0):
    nv, nu = system.nv, system.n_u

    def step(dx, du, dm):
        q1 = system.integrate(q, dx[:nv])
        integ.system = system.with_target_mass(system.target_mass + dm) if dm else system
        try:
            qn, vn = integ.step(q1, v + dx[nv:], t, h, u_extra=du, refresh=True)
        finally:
            integ.system = system
        return qn, vn

    q0, v0 = step(np.zeros(2 * nv), np.zeros(nu), 0.0)

    def diff(plus, minus, eps):
        return np.concatenate([system.difference(minus[0], plus[0]), plus[1] - minus[1]]) / (2 * eps)

    Fx = np.zeros((2 * nv, 2 * nv))
    for j in range(2 * nv):
        e = np.zeros(2 * nv)
        e[j] = eps_x
        Fx[:, j] = diff(step(e, np.zeros(nu), 0.0), step(-e, np.zeros(nu), 0.0), eps_x)
    Fu = np.zeros((2 * nv, nu))
    for j in range(nu):
        e = np.zeros(nu)
        e[j] = 1e-3
        Fu[:, j] = diff(step(np.zeros(2 * nv), e, 0.0), step(np.zeros(2 * nv), -e, 0.0), 1e-3)
    def mass_step(dm):
        qn, vn = step(np.zeros(2 * nv), np.zeros(nu), dm)
        return np.concatenate([system.difference(q0, qn), vn])

    Fm = fd4(mass_step, 0.0, eps_m)
    return Fx, Fu, Fm


def _rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


@pytest.mark.parametrize("method,h", [("sdirk3", 0.05), ("rk4", 0.001)])
def test_step_jacobian_matches_central_differences(envisat, method, h):
    system = build_system(envisat)
    integ = make_integrator(system, method, newton_tol=1e-15)
    walker = make_integrator(system, "sdirk3")
    q, v, t = _state_after(system, walker, 21.0)  # tumbling, deflected, thrusters and arm excited
    res = integ.step_jacobian(q, v, t, h)
    Fx, Fu, Fm = _fd_jacobian(system, integ, q, v, t, h)
    nv = system.nv
    # compare block by block: the blocks have very different scales
    for rows in (slice(0, nv), slice(nv, 2 * nv)):
        for cols in (slice(0, nv), slice(nv, 2 * nv)):
            assert _rel(res.Fx[rows, cols], Fx[rows, cols]) < 1e-6
    assert _rel(res.Fu, Fu) < 1e-6
    assert _rel(res.Fm, Fm) < 1e-6
    # the step taken with the Jacobian is the ordinary step
    q1, v1 = integ.step(q, v, t, h, refresh=True)
    np.testing.assert_allclose(res.v, v1, rtol=0, atol=1e-12)


def test_mass_derivative_of_acceleration(envisat):
    system = build_system(envisat)
    q, v = initial_state(system)
    t = 25.0
    ddq, _, _, Minv = ref.derivatives(system, q, v, t)
    analytic = ref.ddq_dmass(system, q, v, ddq, Minv)
    m0 = system.target_mass

    def acc(m):
        return ref.acceleration(system.with_target_mass(m), q, v, t)

    fd = fd4(acc, m0, 5.0)
    assert _rel(analytic, fd) < 1e-6  # finite differences are round-off bound near 1e-8 here


def test_target_mass_changes_only_the_hub(envisat):
    system = build_system(envisat)
    m_panels = system.layout.target_panel_mass
    assert system.target_mass == pytest.approx(envisat.target.mass, rel=1e-12)
    heavier = system.with_target_mass(7727.9)
    assert heavier.target_mass == 7727.9
    assert system.target_mass == pytest.approx(envisat.target.mass, rel=1e-12)  # the original is unchanged
    j = system.target_joint
    back = heavier.with_target_mass(envisat.target.mass)
    np.testing.assert_allclose(back.joint_inertia(j), build_system(envisat).joint_inertia(j), rtol=1e-12, atol=1e-9)
    with pytest.raises(ValueError, match="target_mass"):
        system.with_target_mass(m_panels)
