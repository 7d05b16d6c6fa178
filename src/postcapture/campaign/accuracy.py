"""Accuracy of the truth integrators against a fine RK4 reference (``postcapture bench --accuracy``).

The L-stable SDIRK steps are not limited by the stiff arm modes (213 Hz here), but they damp and
detune whatever they do not resolve; this measures how far their trajectories sit from RK4 at a step
small enough to resolve every mode, on the default scenario, forced (its manoeuvre) and free.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from postcapture.config import load_scenario
from postcapture.core.rotations import rotation_angle
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.simulate import simulate_system

__all__ = ["integrator_accuracy", "ARCSEC"]

ARCSEC = np.pi / (180.0 * 3600.0)
CASES = (("sdirk3", 0.025), ("sdirk3", 0.05), ("sdirk3", 0.1), ("sdirk2", 0.05), ("rk4", 1e-3))


def _errors(traj, ref, panel: str) -> dict:
    def rel(name):
        return float(np.abs(traj[name] - ref[name]).max() / np.abs(ref[name]).max())

    return {
        "attitude_arcsec": float(rotation_angle(traj["q_BN"], ref["q_BN"]).max() / ARCSEC),
        "rate_rad_s": float(np.abs(traj["omega_BN_B"] - ref["omega_BN_B"]).max()),
        "tip_rel": rel(f"tip_{panel}"),
        "accel_rel": rel("accel_B"),
        "arm_ddq_rel": rel("arm_ddq"),
    }


def integrator_accuracy(
    scenario_name: str = "envisat",
    duration: float = 40.0,
    ref_step: float = 2.5e-4,
    cases=CASES,
    progress: Callable[[str], None] | None = None,
    task_progress: Callable[[str, float], None] | None = None,
) -> dict:
    """Maximum deviations from RK4 at ``ref_step`` over ``duration`` seconds, forced and free.

    Returns ``{"forced": {"sdirk3 h=0.1": {...}, ...}, "free": {...}}`` with attitude (arcsec), body
    rate (rad/s), and the largest deviation of the panel tip deflection, chaser acceleration and arm
    joint accelerations relative to their largest value, plus the wall time of each run.
    ``progress(message)`` is called as each run starts, ``task_progress(run, fraction)`` as it advances.
    """

    def runner(name):
        return None if task_progress is None else (lambda fraction: task_progress(name, fraction))

    scenario = load_scenario(scenario_name)
    panel = scenario.target.panels[0].name if scenario.target and scenario.target.panels else scenario.chaser.panels[0].name
    out: dict = {"duration_s": duration, "reference": f"rk4 h={ref_step}"}
    for label, forced in (("forced", True), ("free", False)):
        system = build_system(scenario, excitation=forced)
        q0, v0 = initial_state(system)
        if progress:
            progress(f"{label}: reference rk4 h={ref_step}")
        ref = simulate_system(system, q0, v0, duration, step=ref_step, sample_period=0.1, integrator="rk4",
                              progress=runner(f"{label} rk4 h={ref_step}"))
        rows = {}
        for method, h in cases:
            if progress:
                progress(f"{label}: {method} h={h}")
            t0 = time.perf_counter()
            traj = simulate_system(system, q0, v0, duration, step=h, sample_period=0.1, integrator=method,
                                   progress=runner(f"{label} {method} h={h}"))
            rows[f"{method} h={h}"] = {**_errors(traj, ref, panel), "wall_s": time.perf_counter() - t0}
        out[label] = rows
    return out
