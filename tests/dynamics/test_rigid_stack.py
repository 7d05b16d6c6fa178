"""With every joint locked the stack is one rigid body: compare with Euler's equations.

The composite inertia is computed here independently of Pinocchio, from the scenario's numbers, by
forward kinematics of the arm at rest and the parallel-axis theorem.
"""

import numpy as np
import pinocchio as pin
import pinocchio_reference as ref
import pytest
from scipy.integrate import solve_ivp

from postcapture.config.types import rpy_matrix
from postcapture.core.rotations import box_minus, quat_rate
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.simulate import simulate_system


def _axis_rotation(axis, angle):
    c, s = np.cos(angle), np.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _plate(m, L, w):
    return np.array([L / 2, 0, 0]), np.diag([m * w * w / 12, m * L * L / 12, m * (L * L + w * w) / 12])


def composite_inertia(sc):
    """Mass, CoM and inertia about the CoM (B axes) of the whole stack at rest."""
    parts = []  # (m, position of CoM in B, inertia about own CoM in B axes)
    parts.append((sc.chaser.mass, np.zeros(3), np.array(sc.chaser.inertia)))
    for p in sc.chaser.panels:
        R, t = rpy_matrix(p.mount.rpy), np.array(p.mount.xyz)
        c, I = _plate(p.mass, p.length, p.width)
        parts.append((p.mass, R @ c + t, R @ I @ R.T))
    R, t = rpy_matrix(sc.arm.base.rpy), np.array(sc.arm.base.xyz)
    for j in sc.arm.joints:
        t = t + R @ np.array(j.origin.xyz)
        R = R @ rpy_matrix(j.origin.rpy) @ _axis_rotation(j.axis, j.rest_angle)
        parts.append((j.mass, t + R @ np.array(j.com), R @ np.array(j.inertia) @ R.T))
    t = t + R @ np.array(sc.arm.tool.xyz)
    R = R @ rpy_matrix(sc.arm.tool.rpy)
    t = t + R @ np.array(sc.target.grasp_to_com.xyz)
    R = R @ rpy_matrix(sc.target.grasp_to_com.rpy)
    assert sc.target.properties_include_panels  # the published tensor is the whole target's
    parts.append((sc.target.mass, t, R @ np.array(sc.target.inertia) @ R.T))
    m = sum(p[0] for p in parts)
    com = sum(p[0] * p[1] for p in parts) / m
    I = np.zeros((3, 3))
    for mi, ci, Ii in parts:
        r = ci - com
        I += Ii + mi * (r @ r * np.eye(3) - np.outer(r, r))
    return m, com, I


def euler_reference(I, omega0, q0, t_eval):
    Iinv = np.linalg.inv(I)

    def rhs(t, y):
        w, q = y[:3], y[3:]
        return np.concatenate([Iinv @ (-np.cross(w, I @ w)), quat_rate(q, w)])

    sol = solve_ivp(rhs, (t_eval[0], t_eval[-1]), np.concatenate([omega0, q0]), t_eval=t_eval,
                    method="DOP853", rtol=1e-12, atol=1e-14)
    q = sol.y[3:] / np.linalg.norm(sol.y[3:], axis=0)
    return sol.y[:3], q


# The scenario's tumble, and a 4.9 deg/s tumble about a non-principal axis (e.Deorbit's design limit
# is 5 deg/s about any axis) whose strong nutation makes the comparison discriminating.
TUMBLES = [None, (0.03, 0.05, 0.06)]


@pytest.mark.parametrize("omega0", TUMBLES)
@pytest.mark.parametrize("integrator,step,tol", [("rk4", 0.02, 1e-11), ("sdirk3", 0.02, 1e-8)])
def test_locked_stack_follows_euler(envisat, integrator, step, tol, omega0):
    sc = envisat
    if omega0 is not None:
        sc = envisat.with_updates(initial={**envisat.initial.model_dump(), "omega_BN_B": omega0})
    system = build_system(sc, "rigid", excitation=False)
    assert system.nv == 6
    q0, v0 = initial_state(system)
    m, com, I = composite_inertia(sc)
    T = 120.0
    traj = simulate_system(system, q0, v0, T, step=step, sample_period=1.0, integrator=integrator)
    w_ref, q_ref = euler_reference(I, np.array(sc.initial.omega_BN_B), np.array(sc.initial.q_BN), traj.t)
    # the reference really nutates: the body rate changes direction
    assert omega0 is None or np.abs(w_ref - w_ref[:, :1]).max() > 1e-3
    w_err = np.abs(traj["omega_BN_B"] - w_ref).max()
    att_err = np.linalg.norm(box_minus(traj["q_BN"], q_ref), axis=0).max()
    assert w_err < tol, w_err
    assert att_err < 100 * tol, att_err
    # The stack's centre of mass stays at rest at the origin.
    assert np.abs(traj["com_N"]).max() < 1e-9


def test_composite_inertia_matches_pinocchio_reduced_model(envisat):
    system = build_system(envisat, "rigid")
    m, com, I = composite_inertia(envisat)
    Y = pin.Inertia.FromDynamicParameters(system.joint_inertia(0))
    reduced, _ = ref.scenario_model(envisat, "rigid")  # Pinocchio's buildReducedModel of its own tree
    np.testing.assert_allclose(Y.toDynamicParameters(), reduced.inertias[1].toDynamicParameters(), rtol=1e-12,
                               atol=1e-9)
    assert Y.mass == pytest.approx(m, rel=1e-12)
    np.testing.assert_allclose(Y.lever, com, atol=1e-9)
    np.testing.assert_allclose(Y.inertia, I, rtol=1e-10, atol=1e-6)
