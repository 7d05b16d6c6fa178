"""Outputs against independent computations: Pinocchio's frame kinematics, the rigid composite body."""

import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pinocchio_reference as ref
import pytest

from postcapture.core.rotations import dcm_from_quat
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.outputs import OutputRecorder

sys.path.insert(0, str(Path(__file__).parent))
from test_rigid_stack import composite_inertia  # noqa: E402


def test_accelerometer_matches_pinocchio_frame_acceleration(envisat):
    system = build_system(envisat)
    q, v = initial_state(system)
    rng = np.random.default_rng(3)
    v = v + rng.normal(scale=0.01, size=v.size)  # generic motion, joint rates too
    rec = OutputRecorder(system, 1)
    ddq = rec.record(0, q, v, 30.0)
    model, data = ref.pin_data(system)
    pin.forwardKinematics(model, data, q, v, ddq)
    fid = model.getFrameId("accelerometer")
    expected = pin.getFrameClassicalAcceleration(model, data, fid, pin.ReferenceFrame.LOCAL).linear
    np.testing.assert_allclose(rec.values["accel_B"][:, 0], expected, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(rec.values["arm_ddq"][:, 0], ddq[list(system.layout.arm_v)], rtol=0, atol=0)


def test_rigid_rotation_momentum_and_energy(envisat):
    """Undeformed and turning rigidly: H = C_NB I_c w, E = w.I_c w / 2, p = 0, no elastic energy."""
    sc = envisat.with_updates(initial={**envisat.initial.model_dump(), "elastic": "undeformed"})
    system = build_system(sc)
    q, v = initial_state(system)
    rec = OutputRecorder(system, 1)
    rec.record(0, q, v, 0.0)
    _, _, I = composite_inertia(sc)
    w = np.array(sc.initial.omega_BN_B)
    C_NB = dcm_from_quat(np.array(sc.initial.q_BN)).T
    np.testing.assert_allclose(rec.values["angular_momentum_N"][:, 0], C_NB @ I @ w, rtol=1e-9)
    assert rec.values["energy_kinetic"][0, 0] == pytest.approx(0.5 * w @ I @ w, rel=1e-9)
    assert rec.values["energy_elastic"][0, 0] == 0.0
    np.testing.assert_allclose(rec.values["momentum_N"][:, 0], 0.0, atol=1e-10)
    np.testing.assert_allclose(rec.values["com_N"][:, 0], 0.0, atol=1e-12)


def test_tip_deflection_of_a_root_hinge_rotation(envisat):
    system = build_system(envisat)
    q = system.assembly.q_rest.copy()
    v = np.zeros(system.nv)
    panel = next(p for p in system.layout.panels if p.name == "envisat_wing")
    theta = 0.02
    q[panel.bending_v[0] + 1] = theta  # the root bending hinge, about the panel's y axis
    rec = OutputRecorder(system, 1)
    rec.record(0, q, v, 0.0)
    L = panel.length
    np.testing.assert_allclose(rec.values["tip_envisat_wing"][:, 0], [L * np.cos(theta) - L, 0.0, -L * np.sin(theta)], atol=1e-12)
    np.testing.assert_allclose(rec.values["tip_chaser_wing"][:, 0], 0.0, atol=1e-12)


def test_relaxed_start_has_no_elastic_acceleration(envisat):
    system = build_system(envisat)
    q, v = initial_state(system)
    ddq = ref.acceleration(system, q, v, 0.0)  # the start is relaxed by the core; checked with Pinocchio
    assert np.abs(ddq[6:]).max() < 1e-9
    assert np.abs(q[7:]).max() > 1e-6  # the tumble does deflect the joints
    model, data = ref.pin_data(system)
    np.testing.assert_allclose(pin.centerOfMass(model, data, q, v), 0.0, atol=1e-12)
    np.testing.assert_allclose(data.vcom[0], envisat.initial.com_velocity_N, atol=1e-12)
