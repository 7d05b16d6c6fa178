"""Integrator tables and observed orders of convergence on SE(3), in the compiled core.

The rigid stack turns and translates on SE(3) (its centre of mass is off the chaser's origin), so a
Lie-group RK4 without the Munthe-Kaas correction of its stages would show order 2 here.
"""

import numpy as np
import pytest

from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.integrators import TABLEAUX


@pytest.mark.parametrize("name", sorted(TABLEAUX))
def test_butcher_identities(name):
    tab = TABLEAUX[name]
    A, b, c = tab.A, tab.b, tab.c
    np.testing.assert_allclose(A.sum(axis=1), c, atol=1e-15)
    conditions = [(b.sum(), 1.0), (b @ c, 1 / 2), (b @ c**2, 1 / 3), (b @ A @ c, 1 / 6),
                  (b @ c**3, 1 / 4), (b @ (c * (A @ c)), 1 / 8), (b @ A @ c**2, 1 / 12), (b @ A @ A @ c, 1 / 24)]
    n_conditions = {1: 1, 2: 2, 3: 4, 4: 8}[tab.order]
    for value, expected in conditions[:n_conditions]:
        assert value == pytest.approx(expected, abs=1e-14)
    assert np.all(np.triu(A, 1) == 0)


@pytest.mark.parametrize("name", ["sdirk2", "sdirk3", "sdirk4"])
def test_sdirk_is_l_stable(name):
    tab = TABLEAUX[name]
    one = np.ones(tab.stages)
    r_inf = 1 - tab.b @ np.linalg.solve(tab.A, one)  # stability function at infinity
    assert abs(r_inf) < 1e-14
    for z in 1j * np.logspace(-2, 4, 50):  # A-stable on the imaginary axis
        r = 1 + z * tab.b @ np.linalg.solve(np.eye(tab.stages) - z * tab.A, one)
        assert abs(r) <= 1 + 1e-12


def _rigid(envisat):
    sc = envisat.with_updates(initial={**envisat.initial.model_dump(), "omega_BN_B": (0.03, 0.05, 0.06)})
    system = build_system(sc, "rigid", excitation=False)
    return system, *initial_state(system)


def _final(system, q, v, method, h, T):
    plant = CompiledPlant(system, method)
    plant.set_newton(1e-14, 1e-16, 40)
    for k in range(int(round(T / h))):
        q, v = plant.step(q, v, k * h, h)
    return q, v


@pytest.mark.parametrize("method", ["rk4", "sdirk4", "sdirk3", "sdirk2"])
def test_observed_order_on_se3(envisat, method):
    system, q0, v0 = _rigid(envisat)
    T = 40.0
    q_ref, v_ref = _final(system, q0, v0, "rk4", 0.0125, T)
    hs = np.array([4.0, 2.0, 1.0]) if method == "rk4" else np.array([2.0, 1.0, 0.5])
    errs = []
    for h in hs:
        q, v = _final(system, q0, v0, method, h, T)
        errs.append(np.abs(system.difference(q_ref, q)).max() + np.abs(v - v_ref).max())
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert order == pytest.approx(TABLEAUX[method].order, abs=0.3), (order, errs)
