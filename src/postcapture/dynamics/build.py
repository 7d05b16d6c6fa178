"""One call from a scenario to a ready :class:`System`, and its initial state."""

from __future__ import annotations

import dataclasses

import numpy as np

from postcapture.config.limits import check_resources, degrees_of_freedom, estimate_model
from postcapture.config.schema import Scenario
from postcapture.core.errors import SimulationError
from postcapture.core.rotations import dcm_from_quat, quat_to_pinocchio
from postcapture.dynamics.assembly import assemble
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.excitation import InputSchedule
from postcapture.dynamics.system import System

__all__ = ["build_system", "initial_state"]


def build_system(
    scenario: Scenario,
    variant: str = "flexible",
    *,
    panel_segments: int | None = None,
    damping: bool = True,
    excitation: bool = True,
) -> System:
    """Build the plant of a scenario.

    Parameters
    ----------
    scenario : Scenario
    variant : {"flexible", "stiff", "rigid"}
    panel_segments : int, optional
        Cut every panel into this many segments (stiffnesses derived from EI(s)).
    damping : bool
        False zeroes every damper (for conservation checks).
    excitation : bool
        False drops the scenario's excitation (a free, unforced system).

    Examples
    --------
    >>> from postcapture.config import load_scenario
    >>> system = build_system(load_scenario("envisat"))
    >>> system.nv
    25
    """
    if panel_segments is not None:
        scenario = scenario.with_panel_segments(panel_segments)
    check_resources(estimate_model(degrees_of_freedom(scenario, variant)))
    assembly = assemble(scenario, variant)
    if not damping:
        assembly = dataclasses.replace(assembly, springs=assembly.springs.without_damping())
    inputs = InputSchedule(scenario.excitation, scenario.n_arm, enabled=excitation)
    return System(assembly, inputs, scenario=scenario)


def _place_com(plant: CompiledPlant, q: np.ndarray, v: np.ndarray, omega_B, com_velocity_N) -> None:
    """Put the system's centre of mass at the origin of N, moving at ``com_velocity_N``, with the whole
    tree turning rigidly at ``omega_B`` (joint rates zero); the centre of mass from the core."""
    q[:3] = 0.0
    com = plant.center_of_mass(q)
    q[:3] = -com
    C_BN = dcm_from_quat(np.concatenate([q[6:7], q[3:6]]))
    c_B = C_BN @ com  # CoM relative to the B origin, B components
    v[:] = 0.0
    v[3:6] = omega_B
    v[:3] = C_BN @ np.asarray(com_velocity_N, dtype=float) - np.cross(omega_B, c_B)


def initial_state(system: System, t0: float = 0.0, tol: float = 1e-11, max_iter: int = 50, *,
                  plant: CompiledPlant | None = None):
    """The scenario's initial configuration and velocity.

    With ``elastic = "relaxed"`` the elastic coordinates are solved (Newton with the analytic
    ``ddq_dq``) so that, turning rigidly at the initial rate under the inputs at ``t0``, they have no
    acceleration: the run starts without a spurious transient. ``plant`` (an instance of the same
    system, e.g. a filter's with its own parameters) is used instead of a new one.

    Returns
    -------
    q0 : ndarray, shape (nq,)
    v0 : ndarray, shape (nv,)
    """
    init = system.scenario.initial
    plant = CompiledPlant(system) if plant is None else plant
    q = system.assembly.q_rest.copy()
    q[3:7] = quat_to_pinocchio(np.asarray(init.q_BN, dtype=float))
    v = np.zeros(system.nv)
    omega = np.asarray(init.omega_BN_B, dtype=float)
    _place_com(plant, q, v, omega, init.com_velocity_N)
    if init.elastic == "relaxed" and system.n_e:
        _relax(system, plant, q, v, omega, t0, tol, max_iter)
    return q, v


def _relax(system: System, plant: CompiledPlant, q, v, omega, t0: float, tol: float, max_iter: int) -> None:
    """Newton on the elastic coordinates until their accelerations vanish (to ``tol``, or to the round-off
    floor: a residual below 1e-7 of the scale that no longer halves)."""
    init = system.scenario.initial
    u0 = system.input_vector(t0)
    previous = np.inf
    for _ in range(max_iter):
        ddq, dq, _, _, _ = plant.derivatives(q, v, u0)
        r = ddq[6:]
        scale = max(1.0, float(np.abs(ddq[:6]).max()))
        residual = float(np.abs(r).max())
        if residual <= tol * scale or (residual <= 1e-7 * scale and residual > 0.5 * previous):
            return
        previous = residual
        q[7:] += np.linalg.solve(dq[6:, 6:], -r)
        _place_com(plant, q, v, omega, init.com_velocity_N)
    raise SimulationError(f"initial state: elastic relaxation did not converge (residual {residual:.3g})")
