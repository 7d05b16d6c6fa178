"""Error against cost of each truth integrator (``postcapture bench --accuracy``).

Every method runs the default scenario on the compiled core at several steps; its largest deviation
from a converged reference (RK4 at 0.25 ms, which resolves every mode including the 213 Hz arm modes)
is set against its CPU time, forced (the scenario's manoeuvre) and free. The implicit methods accept
Newton's iterations as a truth at the scenario's tolerance (1 arcsec when it sets none) does (:func:`~postcapture.dynamics.accuracy.newton_for`).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from postcapture.config import load_scenario
from postcapture.core.rotations import rotation_angle
from postcapture.config.schema import ARCSEC as ARCSEC_RAD
from postcapture.dynamics.accuracy import newton_for
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.simulate import simulate_system

__all__ = ["integrator_accuracy", "accuracy_table", "ARCSEC", "CASES"]

ARCSEC = np.pi / (180.0 * 3600.0)
CASES = (
    ("sdirk4", 0.05), ("sdirk4", 0.025), ("sdirk4", 0.0125),
    ("sdirk3", 0.1), ("sdirk3", 0.025), ("sdirk3", 0.0125), ("sdirk3", 0.01),
    ("sdirk2", 0.01), ("rk4", 0.002),
)


def _errors(traj, ref, panel: str) -> dict:
    def rel(name):
        return float(np.abs(traj[name] - ref[name]).max() / np.abs(ref[name]).max())

    return {
        "attitude_arcsec": float(rotation_angle(traj["q_BN"], ref["q_BN"]).max() / ARCSEC),
        "joint_rad": float(np.abs(traj.q[7:] - ref.q[7:]).max()),
        "rate_rad_s": float(np.abs(traj["omega_BN_B"] - ref["omega_BN_B"]).max()),
        "tip_rel": rel(f"tip_{panel}"),
        "accel_rel": rel("accel_B"),
        "arm_ddq_rel": rel("arm_ddq"),
    }


def integrator_accuracy(
    scenario_name: str = "envisat",
    duration: float = 300.0,
    ref_step: float = 2.5e-4,
    cases=CASES,
    free: bool = True,
    progress: Callable[[str], None] | None = None,
    task_progress: Callable[[str, float], None] | None = None,
) -> dict:
    """Largest deviations from RK4 at ``ref_step`` over ``duration`` seconds, with the CPU time of each run.

    Returns ``{"forced": {"sdirk4 h=0.025": {...}, ...}, "free": {...}}``: attitude (arcsec), joint
    angles (rad), body rate (rad/s), the panel tip deflection, chaser acceleration and arm joint
    accelerations relative to their largest value, ``cpu_s`` and the real-time factor ``rtf``.
    ``progress(message)`` is called as each run starts, ``task_progress(run, fraction)`` as it advances.
    """

    def runner(name):
        return None if task_progress is None else (lambda fraction: task_progress(name, fraction))

    scenario = load_scenario(scenario_name)
    panel = scenario.target.panels[0].name if scenario.target and scenario.target.panels else scenario.chaser.panels[0].name
    sp = scenario.simulation.sample_period
    # every implicit method with the Newton acceptance a truth at the scenario's tolerance gets
    newton = newton_for(scenario.simulation.tolerance or ARCSEC_RAD)
    out: dict = {"duration_s": duration, "reference": f"rk4 h={ref_step}"}
    for label, forced in (("forced", True), ("free", False)) if free else (("forced", True),):
        system = build_system(scenario, excitation=forced)
        q0, v0 = initial_state(system)
        if progress:
            progress(f"{label}: reference rk4 h={ref_step}")
        ref = simulate_system(system, q0, v0, duration, step=ref_step, sample_period=sp, integrator="rk4",
                              progress=runner(f"{label} rk4 h={ref_step}"))
        rows = {}
        for method, h in cases:
            if progress:
                progress(f"{label}: {method} h={h}")
            t0 = time.process_time()
            traj = simulate_system(system, q0, v0, duration, step=h, sample_period=sp, integrator=method,
                                   progress=runner(f"{label} {method} h={h}"), newton=newton)
            cpu = time.process_time() - t0
            rows[f"{method} h={h}"] = {**_errors(traj, ref, panel), "cpu_s": cpu, "rtf": duration / cpu}
        out[label] = rows
    from postcapture.studies.bench import machine_info

    out["machine"] = machine_info()
    out["scenario"] = scenario_name
    out["date"] = time.strftime("%Y-%m-%d")
    return out


def accuracy_table(result: dict) -> str:
    """The Markdown table of :func:`integrator_accuracy` (what BENCHMARKS.md quotes), with the machine."""
    m = result.get("machine", {})
    lines = [
        f"Largest deviation over {result['duration_s']:g} s from {result['reference']}, scenario "
        f"{result.get('scenario', '?')}, {result.get('date', '')}; machine: {m.get('cpu', '?')}, {m.get('cores', '?')} "
        f"cores, Python {m.get('python', '?')}, numpy {m.get('numpy', '?')}, {m.get('compiler', '?')} "
        f"({m.get('cflags', '')}). Attitude in arcsec; joint angles in rad; tip deflection, chaser acceleration "
        "and arm joint accelerations relative to their largest value; real-time factor on CPU time.",
        "",
        "| case | method | attitude (arcsec) | joints (rad) | tip | chaser accel | arm ddq | real-time factor |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for label in ("forced", "free"):
        for name, r in result.get(label, {}).items():
            lines.append(f"| {label} | {name} | {r['attitude_arcsec']:.3g} | {r['joint_rad']:.2e} | {r['tip_rel']:.2e} | "
                         f"{r['accel_rel']:.2e} | {r['arm_ddq_rel']:.2e} | {r['rtf']:.0f} |")
    return "\n".join(lines)
