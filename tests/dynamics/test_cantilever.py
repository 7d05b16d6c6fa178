"""A panel chain on a fixed base converges to the Euler-Bernoulli cantilever as N grows."""

import numpy as np
import pytest

from postcapture.config.flexibility import stiffness_from_ei
from postcapture.config.schema import Panel
from postcapture.dynamics.assembly import assemble_panel_chain
from postcapture.dynamics.modes import structural_modes
from postcapture.dynamics.system import System

L, M, W, EI = 14.0, 350.0, 5.0, 1.2e5
BETA1 = 1.8751040687119611  # first root of cos(b) cosh(b) = -1


def first_bending_frequency(n):
    k = stiffness_from_ei([0.0, L], [EI], L, n)
    panel = Panel(name="strip", length=L, width=W, mass=M, segments=n, bending_stiffness=tuple(k), torsion_stiffness=1e4)
    modes = [m for m in structural_modes(System(assemble_panel_chain(panel))) if m.dominant == "strip bending"]
    return modes[0].frequency_hz


def test_chain_converges_to_euler_bernoulli_with_order_two():
    f_eb = BETA1**2 / (2 * np.pi) * np.sqrt(EI / ((M / L) * L**4))
    ns = np.array([4, 8, 16, 32, 64])
    err = np.array([abs(first_bending_frequency(n) - f_eb) / f_eb for n in ns])
    assert np.all(np.diff(err) < 0)
    order = -np.polyfit(np.log(ns), np.log(err), 1)[0]
    assert order == pytest.approx(2.0, abs=0.1), order
    assert err[-1] < 2e-4  # about 0.46 / N^2


def test_envisat_panel_modes_converge_when_refined(envisat):
    """The Envisat wing, refined from the reference's 5-segment table through EI(s), keeps its low modes."""
    wing = next(p for h, p in envisat.panels() if p.name == "envisat_wing")
    f = []
    for n in (5, 10, 20, 40, 80):
        modes = [m for m in structural_modes(System(assemble_panel_chain(wing.with_segments(n)))) if "bending" in m.dominant]
        f.append([m.frequency_hz for m in modes[:2]])
    f = np.array(f)
    d = np.abs(np.diff(f, axis=0))
    # successive refinements change the first two modes less and less (Cauchy convergence)
    assert np.all(d[1:] < d[:-1])
    assert d[-1, 0] / f[-1, 0] < 1e-3
