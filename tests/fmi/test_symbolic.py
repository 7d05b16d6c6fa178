"""The CasADi plant against Pinocchio: ABA, springs and mass parameters, integrate, dIntegrate, outputs."""

import numpy as np
import pinocchio as pin
import pytest

import casadi as ca  # noqa: F401 - the fmi extra is part of the test install

from postcapture.dynamics.assembly import assemble  # noqa: E402
from postcapture.dynamics.build import build_system  # noqa: E402
from postcapture.dynamics.outputs import OutputRecorder  # noqa: E402
from postcapture.dynamics.system import System  # noqa: E402
from postcapture.fmi.symbolic.functions import build_functions  # noqa: E402
from postcapture.fmi.symbolic.plant import SymbolicPlant  # noqa: E402


def _states(system, rng, n=12):
    for _ in range(n):
        q = pin.randomConfiguration(system.model, -np.ones(system.nq), np.ones(system.nq))
        q[:3] *= 10.0
        yield q, 0.3 * rng.standard_normal(system.nv), 10.0 * rng.standard_normal(system.n_u)


@pytest.mark.parametrize("variant", ["flexible", "stiff", "rigid"])
def test_aba_matches_pinocchio(envisat, variant):
    system = build_system(envisat, variant)
    plant = SymbolicPlant(system)
    f = build_functions(plant)["pc_ddq"]
    p = plant.parameter_values()
    rng = np.random.default_rng(5)
    worst = 0.0
    for q, v, u in _states(system, rng):
        ref = system.acceleration_u(q, v, u)
        got = np.array(f(q, v, u, p)).ravel()
        worst = max(worst, np.abs(got - ref).max() / np.abs(ref).max())
    assert worst <= 1e-9


def test_mass_and_spring_parameters(envisat):
    system = build_system(envisat)
    plant = SymbolicPlant(system)
    f = build_functions(plant)["pc_ddq"]
    names = [p.name for p in plant.parameters]
    p = plant.parameter_values()
    rng = np.random.default_rng(6)
    # target mass: the hub mass changes at fixed centre of mass and inertia about it
    other = system.copy()
    other.target_mass = 5000.0
    p_m = p.copy()
    p_m[names.index("target_mass")] = 5000.0
    # springs: rebuild a System with other stiffness and damping
    assembly = assemble(envisat)
    springs = assembly.springs
    p_k = p.copy()
    for j, name in enumerate(springs.names):
        springs.k[j] *= 1.5 + 0.1 * j
        springs.d[j] = 3.0 + j
        p_k[names.index(f"k_{name}")] = springs.k[j]
        p_k[names.index(f"d_{name}")] = springs.d[j]
    stiffer = System(assembly, system.inputs)
    for q, v, u in _states(system, rng, 5):
        for sysm, params in ((other, p_m), (stiffer, p_k)):
            ref = sysm.acceleration_u(q, v, u)
            got = np.array(f(q, v, u, params)).ravel()
            assert np.abs(got - ref).max() <= 1e-9 * np.abs(ref).max()


def test_integrate_and_dintegrate(envisat):
    """Integrate to round-off; dIntegrate to 1e-12 (1e-9 below 0.05 rad).

    Below 0.05 rad Pinocchio's own small-angle series for Jexp6 is off by up to about 1e-10 (ours matches
    the closed form to 1e-16).
    """
    system = build_system(envisat)
    plant = SymbolicPlant(system)
    funcs = build_functions(plant)
    rng = np.random.default_rng(7)
    for k, (q, _v, _) in enumerate(_states(system, rng, 20)):
        scale = (1e-3, 0.05, 1.5, 1e-9)[k % 4]
        dq = rng.standard_normal(system.nv) * scale
        if k == 3:
            dq[3:6] = 0.0  # the Taylor branch at exactly zero rotation
        got = np.array(funcs["pc_integ"](q, dq)).ravel()
        assert np.abs(got - pin.integrate(system.model, q, dq)).max() <= 1e-14 * max(1.0, np.abs(q).max())
        J0, Jr = (np.array(M) for M in funcs["pc_dint"](q[:7], dq[:6]))
        ref0 = pin.dIntegrate(system.model, q, dq, pin.ArgumentPosition.ARG0)[:6, :6]
        ref1 = pin.dIntegrate(system.model, q, dq, pin.ArgumentPosition.ARG1)[:6, :6]
        tol = 1e-12 if scale >= 0.05 else 1e-9
        assert np.abs(J0 - ref0).max() <= tol and np.abs(Jr - ref1).max() <= tol


def test_outputs_match_the_recorder(envisat):
    system = build_system(envisat, excitation=False)
    plant = SymbolicPlant(system)
    f = build_functions(plant)["pc_out"]
    rng = np.random.default_rng(8)
    names = [s.name for s in plant.output_signals()]
    for q, v, _ in _states(system, rng, 5):
        rec = OutputRecorder(system, 1)
        ddq = rec.record(0, q, v, 0.0)
        xdot, y = (np.array(a).ravel() for a in f(q, v, ddq))
        ref = []
        for spec in rec.specs:
            if spec.name in (
                "q_BN",
                "omega_BN_B",
                "r_BN_N",
                "accel_B",
                "arm_q",
                "arm_dq",
                "arm_ddq",
            ) or spec.name.startswith(("tip_", "torsion_")):
                ref += list(rec.values[spec.name][:, 0])
        assert len(ref) == len(names)
        assert np.abs(y - np.array(ref)).max() <= 1e-12
        # ambient state derivative: d/dt pinocchio.integrate(q, t v) at t = 0
        eps = 1e-6
        fd = (pin.integrate(system.model, q, eps * v) - pin.integrate(system.model, q, -eps * v)) / (2 * eps)
        assert np.abs(xdot[: system.nq] - fd).max() <= 1e-8
        assert np.abs(xdot[system.nq :] - ddq).max() == 0.0
