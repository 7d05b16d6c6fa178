"""A single spring-hinged rigid panel on a free hub: closed-form frequencies.

Planar two-body system joined by a hinge (hinge axis normal to the plane holding both centres of mass
and the hinge). With I1, I2 the bodies' inertias about their own centres of mass, a1, a2 the distances
from each centre of mass to the hinge and mu = m1 m2 / (m1 + m2), zero total momentum leaves one mode:

    w^2 = k (I1 + I2 + mu (a1 + a2)^2) / (I1 I2 + mu (I1 a2^2 + I2 a1^2)).

The root torsion hinge turns the panel about the line through both centres of mass: w^2 = k_t (1/Ix1 + 1/Ix2).
"""

import numpy as np
import pytest

from postcapture.config import scenario_from_dict
from postcapture.dynamics.build import build_system
from postcapture.dynamics.modes import structural_modes
from postcapture.dynamics.simulate import simulate_system

HUB = dict(mass=500.0, Ixx=100.0, Iyy=150.0, Izz=200.0, hinge=1.0)
PANEL = dict(length=4.0, width=1.0, mass=20.0, k=300.0, k_t=80.0)


def hub_panel_scenario():
    return scenario_from_dict(
        {
            "name": "hub_panel",
            "chaser": {
                "mass": HUB["mass"],
                "inertia": [[HUB["Ixx"], 0, 0], [0, HUB["Iyy"], 0], [0, 0, HUB["Izz"]]],
                "panels": [
                    {
                        "name": "wing",
                        "mount": {"xyz": [HUB["hinge"], 0.0, 0.0]},
                        "length": PANEL["length"],
                        "width": PANEL["width"],
                        "mass": PANEL["mass"],
                        "segments": 1,
                        "bending_stiffness": [PANEL["k"]],
                        "torsion_stiffness": PANEL["k_t"],
                    }
                ],
            },
        }
    )


def closed_form():
    m1, m2 = HUB["mass"], PANEL["mass"]
    L, w = PANEL["length"], PANEL["width"]
    I1, I2 = HUB["Iyy"], m2 * L**2 / 12  # bending turns about y
    a1, a2 = HUB["hinge"], L / 2
    mu = m1 * m2 / (m1 + m2)
    w_bend = np.sqrt(PANEL["k"] * (I1 + I2 + mu * (a1 + a2) ** 2) / (I1 * I2 + mu * (I1 * a2**2 + I2 * a1**2)))
    Ix2 = m2 * w**2 / 12
    w_tors = np.sqrt(PANEL["k_t"] * (1 / HUB["Ixx"] + 1 / Ix2))
    return w_bend / (2 * np.pi), w_tors / (2 * np.pi)


def test_linearised_frequencies_match_closed_form():
    f_bend, f_tors = closed_form()
    system = build_system(hub_panel_scenario())
    assert system.nv == 8
    modes = {m.dominant: m.frequency_hz for m in structural_modes(system)}
    assert modes["wing bending"] == pytest.approx(f_bend, rel=1e-10)
    assert modes["wing torsion"] == pytest.approx(f_tors, rel=1e-10)


def test_free_oscillation_has_closed_form_frequency():
    f_bend, _ = closed_form()
    system = build_system(hub_panel_scenario())
    q0 = system.assembly.q_rest.copy()
    v0 = np.zeros(system.nv)
    i_bend = system.layout.panels[0].bending_v[0]
    q0[i_bend + 1] = 1e-3  # small initial hinge deflection, zero momentum
    period = 1 / f_bend
    traj = simulate_system(system, q0, v0, 10 * period, step=period / 400, sample_period=period / 400, integrator="rk4")
    angle = traj.q[i_bend + 1]
    # upward zero crossings, linearly interpolated
    idx = np.nonzero((angle[:-1] < 0) & (angle[1:] >= 0))[0]
    t_cross = traj.t[idx] - angle[idx] * (traj.t[idx + 1] - traj.t[idx]) / (angle[idx + 1] - angle[idx])
    f_measured = 1 / np.mean(np.diff(t_cross))
    assert len(idx) >= 8
    assert f_measured == pytest.approx(f_bend, rel=2e-5)
    # free and undamped: energy and momentum are conserved
    E = traj["energy"][0]
    assert np.abs(E - E[0]).max() / E[0] < 1e-8
    assert np.abs(traj["momentum_N"]).max() < 1e-10
