"""The speed benchmark behind ``postcapture bench``: real-time factors, step Jacobian cost, build time."""

from __future__ import annotations

import os
import platform
import time
from collections.abc import Callable

import numpy as np

from postcapture.config import load_scenario
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.integrators import make_integrator
from postcapture.dynamics.simulate import simulate_system

__all__ = ["machine_info", "run_benchmark"]


def machine_info() -> dict:
    """CPU, core count and library versions, for BENCHMARKS.md."""
    import pinocchio
    import scipy

    cpu = platform.processor() or "unknown"
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "pinocchio": pinocchio.__version__,
        "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS", "default"),
    }


def _rtf(scenario, n: int, duration: float, repeats: int = 3) -> tuple[float, float, int]:
    """Median and best real-time factor over ``repeats`` runs (this machine's timings jitter by ~20 %)."""
    system = build_system(scenario, panel_segments=n)
    q0, v0 = initial_state(system)
    sim = scenario.simulation
    rtfs = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        simulate_system(system, q0, v0, duration, step=sim.step, sample_period=sim.sample_period, integrator=sim.integrator)
        rtfs.append(duration / (time.perf_counter() - t0))
    return float(np.median(rtfs)), float(max(rtfs)), system.nv


def run_benchmark(
    scenario_name: str = "envisat",
    duration: float = 60.0,
    segments: tuple[int, ...] = (5, 20, 50),
    progress: Callable[[str], None] | None = None,
) -> dict:
    """Measure the truth simulation's speed on the default scenario.

    Returns a dict with ``rtf_n5``, ``rtf_n20``, ``rtf_n50`` (simulated seconds per wall second, outputs
    recorded, median of three runs; ``rtf_best_n*`` the best), ``step_jacobian_ms_n5`` (one exact step Jacobian), ``build_s_n50`` (scenario to ready
    model), the degrees of freedom, the integrator settings and the machine.
    """
    scenario = load_scenario(scenario_name)
    out: dict = {"scenario": scenario_name, "duration_s": duration}
    sim = scenario.simulation
    out.update(integrator=sim.integrator, step_s=sim.step, sample_period_s=sim.sample_period)
    for n in segments:
        if progress:
            progress(f"real-time factor, N = {n}")
        rtf, best, nv = _rtf(scenario, n, duration)
        out[f"rtf_n{n}"] = rtf
        out[f"rtf_best_n{n}"] = best
        out[f"n_dof_n{n}"] = nv
    if progress:
        progress("step Jacobian, N = 5")
    system = build_system(scenario, panel_segments=5)
    q0, v0 = initial_state(system)
    integ = make_integrator(system, sim.integrator)
    integ.step_jacobian(q0, v0, 0.0, sim.step)  # warm up
    reps = 50
    t0 = time.perf_counter()
    q, v = q0, v0
    for k in range(reps):
        res = integ.step_jacobian(q, v, k * sim.step, sim.step)
        q, v = res.q, res.v
    out["step_jacobian_ms_n5"] = (time.perf_counter() - t0) / reps * 1e3
    if progress:
        progress("model build, N = 50")
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        build_system(scenario, panel_segments=50)
        times.append(time.perf_counter() - t0)
    out["build_s_n50"] = min(times)
    out["machine"] = machine_info()
    return out
