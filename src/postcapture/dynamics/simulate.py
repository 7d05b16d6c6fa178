"""Truth simulation: integrate the plant over a run and record its outputs.

The run also integrates, with the integrator's own quadrature, the energy and momentum the inputs and
dampers put in or take out, so that conservation can be checked on any run:

    E(t) - E(0) = W_in(t) - W_damp(t),     H_O(t) - H_O(0) = integral of the external moment about O,

with O the origin of N (the angular momentum about the centre of mass follows from H_O = H_c + c x p).
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable

import numpy as np

from postcapture.config.limits import check_resources, estimate_simulation
from postcapture.config.schema import Scenario
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.integrators import make_integrator
from postcapture.dynamics.outputs import OutputRecorder
from postcapture.dynamics.system import System
from postcapture.dynamics.trajectory import StateLayout, Trajectory

__all__ = ["simulate", "simulate_system", "balance_integrand", "drift_metrics"]


def _rotate(qx, qy, qz, qw, x0, x1, x2):
    """``R(q) x`` for a unit quaternion (Pinocchio order x, y, z, w): B components to N, on floats."""
    t0, t1, t2 = 2.0 * (qy * x2 - qz * x1), 2.0 * (qz * x0 - qx * x2), 2.0 * (qx * x1 - qy * x0)
    return (x0 + qw * t0 + qy * t2 - qz * t1, x1 + qw * t1 + qz * t0 - qx * t2, x2 + qw * t2 + qx * t1 - qy * t0)


def balance_integrand(system: System) -> Callable:
    """``g(q, v, u) = [power in - power dissipated, external moment about N's origin, force]`` (N components).

    The moment is taken about the fixed origin of N (no centre of mass needed in the integrator's
    loop); :func:`drift_metrics` moves the balance to the centre of mass with ``H_O = H_c + c x p``.
    """
    B_T = system.B.T.copy()
    d_full = system._d_full if system._diag else None
    D = system.D_e

    def g(q, v, u):
        power = float(u @ (B_T @ v))
        if system.n_e:
            if d_full is not None:
                power -= float(v @ (d_full * v))
            else:
                w = v[6:]
                power -= float(w @ (D @ w))
        px, py, pz, qx, qy, qz, qw = q[:7].tolist()
        f0, f1, f2, m0, m1, m2 = u[:6].tolist()
        F = _rotate(qx, qy, qz, qw, f0, f1, f2)
        M = _rotate(qx, qy, qz, qw, m0, m1, m2)
        return np.array([power, py * F[2] - pz * F[1] + M[0], pz * F[0] - px * F[2] + M[1],
                         px * F[1] - py * F[0] + M[2], F[0], F[1], F[2]])

    return g


def drift_metrics(traj: Trajectory) -> dict[str, float]:
    """Relative drift of energy and angular momentum, net of what inputs and dampers exchanged.

    ``energy_drift_rel = max |E(t) - E(0) - W(t)| / E(0)``;
    ``angular_momentum_drift_rel = max |H_O(t) - H_O(0) - int M_O dt| / |H_c(0)|`` with the angular
    momentum about N's origin ``H_O = H_c + c x p`` (c the centre of mass, p the linear momentum).
    """
    E = traj["energy"][0]
    W = traj["work_in"][0]
    Hc = traj["angular_momentum_N"]
    H_O = Hc + np.cross(traj["com_N"], traj["momentum_N"], axis=0)
    Mi = traj["moment_impulse_N"]
    e0 = abs(E[0]) if E[0] != 0 else 1.0
    h0 = float(np.linalg.norm(Hc[:, 0])) or 1.0
    return {
        "energy_drift_rel": float(np.max(np.abs(E - E[0] - W)) / e0),
        "angular_momentum_drift_rel": float(np.max(np.linalg.norm(H_O - H_O[:, :1] - Mi, axis=0)) / h0),
    }


def simulate_system(
    system: System,
    q0: np.ndarray,
    v0: np.ndarray,
    duration: float,
    *,
    step: float,
    sample_period: float,
    integrator: str = "sdirk3",
    t0: float = 0.0,
    progress: Callable[[float], None] | None = None,
) -> Trajectory:
    """Integrate a built system from ``(q0, v0)`` and record its outputs every ``sample_period``.

    Parameters
    ----------
    system : System
    q0, v0 : ndarray
        Initial configuration (nq,) and velocity (nv,).
    duration, step, sample_period : float
        Seconds; ``sample_period`` must be a whole multiple of ``step``.
    integrator : {"sdirk3", "sdirk2", "rk4"}
    progress : callable, optional
        Called with the fraction done (0..1) after each sample.

    Returns
    -------
    Trajectory
    """
    ratio = sample_period / step
    per = int(round(ratio))
    if per < 1 or abs(ratio - per) > 1e-9:
        raise ValueError(f"sample_period: expected a whole multiple of step = {step}, found {sample_period}")
    check_resources(estimate_simulation(nv=system.nv, duration=duration, step=step, sample_period=sample_period,
                                        integrator=integrator))
    n = int(round(duration / sample_period)) + 1
    integ = make_integrator(system, integrator)
    rec = OutputRecorder(system, n)
    q_hist = np.zeros((system.nq, n))
    v_hist = np.zeros((system.nv, n))
    a_hist = np.zeros((system.nv, n))
    bal = np.zeros((7, n))
    g = balance_integrand(system)
    q, v = np.array(q0, dtype=float), np.array(v0, dtype=float)
    acc = np.zeros(7)
    wall0 = _time.perf_counter()
    for k in range(n):
        t = t0 + k * sample_period
        if k:
            for j in range(per):
                ts = t0 + (k - 1) * sample_period + j * step
                q, v, dI = integ.step_quadrature(q, v, ts, step, g)
                acc += dI
        q_hist[:, k], v_hist[:, k] = q, v
        a_hist[:, k] = rec.record(k, q, v, t)
        bal[:, k] = acc
        if progress is not None:
            progress((k + 1) / n)
    wall = _time.perf_counter() - wall0
    outputs = dict(rec.values)
    outputs["work_in"] = bal[:1]
    outputs["moment_impulse_N"] = bal[1:4]
    outputs["impulse_N"] = bal[4:7]
    from postcapture.dynamics.outputs import OutputSpec

    specs = rec.specs + [
        OutputSpec("work_in", ("value",), "J", "work done by the inputs minus energy dissipated by the dampers"),
        OutputSpec("moment_impulse_N", ("x", "y", "z"), "N m s", "time integral of the external moment about the origin of N"),
        OutputSpec("impulse_N", ("x", "y", "z"), "N s", "time integral of the external force"),
    ]
    attrs = {
        "integrator": integrator,
        "step_s": step,
        "sample_period_s": sample_period,
        "nq": system.nq,
        "nv": system.nv,
        "wall_s": wall,
        "newton_iterations": integ.stats["newton_iterations"],
    }
    return Trajectory(np.array([t0 + k * sample_period for k in range(n)]), q_hist, v_hist, a_hist, outputs, specs, attrs,
                      layout=StateLayout.from_system(system))


def simulate(
    scenario: Scenario,
    *,
    variant: str = "flexible",
    duration: float | None = None,
    panel_segments: int | None = None,
    damping: bool = True,
    excitation: bool = True,
    integrator: str | None = None,
    step: float | None = None,
    sample_period: float | None = None,
    parameters: dict | None = None,
    progress: Callable[[float], None] | None = None,
) -> Trajectory:
    """Simulate a scenario's truth from its initial state.

    Settings default to the scenario's ``[simulation]`` section; ``parameters`` overrides named model
    parameters (:mod:`postcapture.dynamics.parameters`, e.g. a truth drawn from the priors).

    Examples
    --------
    >>> from postcapture.config import load_scenario
    >>> traj = simulate(load_scenario("envisat"), duration=1.0)
    >>> traj["q_BN"].shape
    (4, 11)
    """
    sim = scenario.simulation
    system = build_system(scenario, variant, panel_segments=panel_segments, damping=damping, excitation=excitation)
    system.update_parameters(parameters or {})
    q0, v0 = initial_state(system)
    traj = simulate_system(
        system,
        q0,
        v0,
        sim.duration if duration is None else duration,
        step=sim.step if step is None else step,
        sample_period=sim.sample_period if sample_period is None else sample_period,
        integrator=sim.integrator if integrator is None else integrator,
        progress=progress,
    )
    traj.attrs.update(
        scenario=scenario.name,
        variant=variant,
        panel_segments=",".join(str(p.segments) for _, p in system.scenario.panels()),
        damping=str(damping),
        excitation=str(excitation),
    )
    return traj
