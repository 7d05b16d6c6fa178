"""The orbit's gravity gradient: against the closed form on a rigid body, and the energy and angular
momentum balances of the whole flexible stack (the moment the balance integrates is computed apart from the
generalized forces the dynamics use, so a wrong joint force breaks it)."""

import numpy as np
import pytest

from postcapture.config import scenario_from_dict
from postcapture.core import rotations as rot
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.simulate import drift_metrics, simulate_system
from postcapture.estimation.increments import tidal_mean_B0


@pytest.fixture
def rigid_body(envisat_dict):
    d = {k: v for k, v in envisat_dict.items() if k not in ("arm", "target", "excitation", "faults", "uncertainty")}
    d["chaser"] = {**d["chaser"], "panels": [], "inertia": [[1500.0, 100.0, -50.0], [100.0, 1300.0, 30.0],
                                                             [-50.0, 30.0, 1200.0]]}
    return scenario_from_dict(d)


def test_the_torque_on_a_rigid_body_is_3n2_r_x_Ir(rigid_body):
    plant = CompiledPlant(build_system(rigid_body, damping=False, excitation=False), "sdirk4")
    n = 0.01
    plant.set_orbit(n)
    q_BN = rot.exp_map(0.7 * np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8]))
    q = np.concatenate([[2.0, -1.0, 0.5], rot.quat_to_pinocchio(q_BN)])
    tau = plant.mass_matrix(q) @ plant.acceleration(q, np.zeros(6), np.zeros(6))
    I = np.array(rigid_body.chaser.inertia)
    C_BN = rot.dcm_from_quat(q_BN)
    r_B = C_BN @ np.array([1.0, 0.0, 0.0])  # the zenith at t = 0, body components
    x_N = q[0:3]  # the body's centre in N: the tidal force on its mass
    F_N = 1600.0 * n**2 * (3.0 * np.array([1.0, 0.0, 0.0]) * x_N[0] - x_N)
    np.testing.assert_allclose(tau[3:], 3 * n**2 * np.cross(r_B, I @ r_B), rtol=1e-10, atol=1e-15)
    np.testing.assert_allclose(tau[:3], C_BN @ F_N, rtol=1e-10, atol=1e-15)


@pytest.mark.parametrize("n", [1.0447e-3, 0.01])
def test_energy_and_angular_momentum_balance_in_orbit(envisat, n):
    system = build_system(envisat, damping=False, excitation=False)
    q0, v0 = initial_state(system)
    traj = simulate_system(system, q0, v0, 100.0, step=0.0125, sample_period=0.1, integrator="sdirk4", mean_motion=n)
    metrics = drift_metrics(traj)
    assert metrics["energy_drift_rel"] < 1e-10 and metrics["angular_momentum_drift_rel"] < 1e-10, metrics
    free = simulate_system(system, q0, v0, 100.0, step=0.0125, sample_period=0.1, integrator="sdirk4")
    moved = np.abs(traj["moment_impulse_N"][:, -1]).max()
    assert moved > 1e-3 * n / 1e-3 and not np.any(free["moment_impulse_N"])  # the field did act


def test_the_tidal_reading_of_a_point_against_the_field():
    n, t0, t1 = 1.0447e-3, 10.0, 10.1
    q = rot.exp_map(np.array([0.1, -0.2, 0.3]))
    r_N, r_B = np.array([3.0, -4.0, 1.0]), np.array([0.3, 0.1, 0.2])
    p = r_N + rot.dcm_from_quat(q).T @ r_B
    mid = 0.5 * (t0 + t1)
    z = np.array([np.cos(n * mid), np.sin(n * mid), 0.0])
    g = n**2 * (3 * z * (z @ p) - p)  # the field at the cycle's middle, N components
    np.testing.assert_allclose(tidal_mean_B0(q, r_N, q, r_N, r_B, n, t0, t1), rot.dcm_from_quat(q) @ g,
                               rtol=1e-7, atol=1e-15)
