"""Continuous linearisation against the exact step Jacobian, and Spong flexible joints with rotors."""

import numpy as np
import pytest
from scipy.linalg import expm

from postcapture.dynamics.build import build_system, initial_state
from lie_oracle import make_integrator
from postcapture.dynamics.modes import linearize
from postcapture.dynamics.simulate import simulate_system


def test_linearisation_is_the_generator_of_the_step_jacobian(envisat):
    """For a small step h, the exact RK4 step Jacobian equals expm(A h) up to O(h^5) (right perturbations)."""
    system = build_system(envisat)
    q, v = initial_state(system)
    v = v + np.random.default_rng(0).normal(scale=1e-3, size=v.size)  # tumbling and vibrating
    t, h = 25.0, 2e-4
    lin = linearize(system, q, v, t)
    F = make_integrator(system, "rk4").step_jacobian(q, v, t, h).Fx
    Phi = expm(lin.A * h)
    assert np.abs(F - Phi).max() / np.abs(Phi - np.eye(Phi.shape[0])).max() < 1e-4
    # the free flyer's own block, with its own scale: this is where -ad_V (right perturbations) lives;
    # leaving it out would make this error 100 %
    ff = np.s_[:6, :6]
    assert np.abs(F[ff] - Phi[ff]).max() / np.abs(Phi[ff] - np.eye(6)).max() < 1e-4
    # and the input and mass columns: B h and E h to first order
    res = make_integrator(system, "rk4").step_jacobian(q, v, t, h)
    np.testing.assert_allclose(res.Fm, lin.E * h + 0.5 * h * h * lin.A @ lin.E, rtol=1e-3, atol=1e-3 * np.abs(res.Fm).max())


def _with_rotors(envisat, rotor=0.5):
    arm = envisat.arm.model_dump()
    for j in arm["joints"]:
        j["rotor_inertia"] = rotor
        j["servo_stiffness"] = 2e5
        j["servo_damping"] = 0.0
        j["damping"] = 0.0
    return envisat.with_updates(arm=arm)


def test_spong_rotors_add_one_coordinate_per_joint_and_conserve_energy(envisat):
    sc = _with_rotors(envisat)
    plain = build_system(envisat)
    system = build_system(sc, damping=False, excitation=False)
    assert system.nv == plain.nv + sc.n_arm
    assert all(r is not None for r in system.layout.rotor_v)
    # the spring couples rotor and link: K has off-diagonal -k between them
    e_link = system.layout.arm_v[0] - 6
    e_rot = system.layout.rotor_v[0] - 6
    assert system.K_e[e_link, e_rot] == pytest.approx(-envisat.arm.joints[0].stiffness)
    assert system.K_e[e_rot, e_rot] == pytest.approx(envisat.arm.joints[0].stiffness + 2e5)
    q0, v0 = initial_state(system)
    traj = simulate_system(system, q0, v0, 20.0, step=0.1, sample_period=0.5)
    E = traj["energy"][0]
    assert np.abs(E - E[0]).max() / E[0] < 1e-8
    H = traj["angular_momentum_N"]
    assert np.linalg.norm(H - H[:, :1], axis=0).max() / np.linalg.norm(H[:, 0]) < 1e-9
