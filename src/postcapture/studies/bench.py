"""The speed benchmark behind ``postcapture bench``: real-time factors, prediction cost, compile time.

Times are process CPU time on one core (BLAS pinned to one thread), the median of ``repeats`` runs,
so that a busy machine disturbs them less than wall time would.
"""

from __future__ import annotations

import os
import platform
import statistics
import tempfile
import time
from collections.abc import Callable

import numpy as np

from postcapture.config import load_scenario
from postcapture.dynamics.accuracy import choose_step, newton_for
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.simulate import simulate_system

__all__ = ["machine_info", "run_benchmark", "compile_time", "campaign_time"]


def machine_info() -> dict:
    """CPU, core count and library versions, for BENCHMARKS.md."""
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
    from postcapture.dynamics.compiled import CFLAGS, compiler

    return {
        "cpu": cpu,
        "cores": os.cpu_count(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "compiler": compiler(),
        "cflags": " ".join(CFLAGS),
    }


def _cpu(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return statistics.median(times)


BENCH_JOINT_TOLERANCE = 1e-4  # rad: the truth accuracy the rtf_* keys were defined at


def compile_time() -> float:
    """Seconds to compile the plant core from scratch (into a throw-away cache)."""
    from postcapture.dynamics import compiled

    with tempfile.TemporaryDirectory(prefix="postcapture_bench_") as tmp:
        t0 = time.perf_counter()
        compiled._build(compiled.compiler(), compiled.source_files(), compiled.Path(tmp) / "core.so")
        return time.perf_counter() - t0


def _rtf(scenario, n: int, duration: float, repeats: int, tolerance: float | None) -> dict:
    from postcapture.config.schema import ARCSEC

    sim = scenario.simulation
    system = build_system(scenario, panel_segments=n)
    q0, v0 = initial_state(system)
    tol = tolerance if tolerance is not None else (sim.tolerance or ARCSEC)
    t0 = time.process_time()
    # the bench's own accuracy (its keys stay comparable across rounds): the attitude at ``tol`` and the
    # joint angles at 1e-4 rad, without the scenario's sensed-rate and encoder tolerances
    step = choose_step(system, q0, v0, duration=duration, sample_period=sim.sample_period, tolerance=tol,
                       joint_tolerance=BENCH_JOINT_TOLERANCE, method=sim.integrator)
    choose_s = time.process_time() - t0
    run_s = _cpu(lambda: simulate_system(system, q0, v0, duration, step=step, sample_period=sim.sample_period,
                                         integrator=sim.integrator, newton=newton_for(tol)), repeats)
    return {"rtf": duration / (run_s + choose_s), "rtf_run_only": duration / run_s, "step_s": step,
            "choose_step_s": choose_s, "n_dof": system.nv}


def _predict_ms(scenario, n: int, repeats: int = 200, *, integrator: str = "sdirk3", step: float = 0.1,
                dt: float = 0.1) -> float:
    """CPU ms of one ``dt`` prediction with every Jacobian, in steps of ``step`` (the ``predict_ms_*`` keys
    keep the former filters' model, SDIRK3 in one 0.1 s step, so that they compare across rounds)."""
    from postcapture.dynamics.process_model import NativeProcessModel

    model = NativeProcessModel(build_system(scenario, panel_segments=n), step, integrator)
    x = model.initial_state()
    for k in range(5):
        x = model.predict(x, 10.0 + k * dt, dt).x
    model.predict(x, 10.5, dt, jacobians=True)
    t0 = time.process_time()
    for _ in range(repeats):
        model.predict(x, 10.5, dt, jacobians=True)
    return (time.process_time() - t0) / repeats * 1e3


def _filter_rtf(scenario, case: str, duration: float, profile: str = "reference") -> float:
    """Simulated seconds per CPU second of one estimation case (the engine's filters over ``duration``).

    The truth, its sensors, the model noise and the filters' prior are computed first and not timed (a campaign
    worker computes the prior once per process): what is timed is the case itself, its filters' set-up included.
    """
    from postcapture.studies.main_job import draw_sensors, run_case, simulate_truth
    from postcapture.studies.robust import with_model_noise
    from postcapture.studies.setup import plan_run

    plan = with_model_noise(plan_run(scenario, profile=profile, duration=duration, cases=(case,)))
    traj = simulate_truth(plan)
    sensors, dq0 = draw_sensors(plan, traj, plan.seed)
    run_case(plan, case, sensors, traj["q_BN"][:, 0], dq0)  # warms the per-process caches (the prior)
    t0 = time.process_time()
    res = run_case(plan, case, sensors, traj["q_BN"][:, 0], dq0)
    cpu = time.process_time() - t0
    if not np.isfinite(res.mass[-1]):
        raise RuntimeError(f"bench: the {case} case failed: {getattr(res.attitude, 'message', '')}")
    return duration / cpu


def campaign_time(scenario_name: str = "envisat", runs: int = 50, workers: int = 2) -> float:
    """Wall seconds of a dispersed campaign of ``dual`` and ``joint`` (realistic profile, 300 s runs, no bounds)."""
    import tempfile as _tf

    from postcapture.studies.montecarlo import run_campaign

    with _tf.TemporaryDirectory(prefix="postcapture_bench_") as tmp:
        t0 = time.perf_counter()
        run_campaign(load_scenario(scenario_name), runs=runs, dispersed=True, cases=("dual", "joint"), workers=workers,
                     out=tmp, fresh=True, crlb=False)
        return time.perf_counter() - t0


def run_benchmark(
    scenario_name: str = "envisat",
    duration: float = 300.0,
    segments: tuple[int, ...] = (5, 50, 200),
    repeats: int = 3,
    main_job: bool = True,
    progress: Callable[[str], None] | None = None,
    campaign: bool = False,
) -> dict:
    """Measure the compiled plant on the default scenario (keys of ``postcapture bench --json``).

    Returns ``rtf_n5``, ``rtf_n50``, ``rtf_n200``: simulated seconds per CPU second of the truth at the
    scenario's tolerance, 1 arcsec when it sets none (its step chosen by :func:`~postcapture.dynamics.accuracy.choose_step`,
    the choice included), every output recorded; ``rtf_n5_1arcsec``: the same at N = 5 with a 1 arcsec
    attitude tolerance; ``predict_ms_n5``, ``predict_ms_n50``: one 0.1 s SDIRK3 prediction with every Jacobian
    (state, inputs, parameters, measurement); ``predict_ms_n5_filters``: the same with the filters' own
    settings (``[estimation] integrator``, ``model_step``); ``filter_rtf_dual_n5``, ``filter_rtf_joint_n5``:
    simulated seconds per CPU second of one case over ``duration`` (reference profile, the engine's filters,
    :func:`_filter_rtf`); ``campaign50_s`` (with ``campaign``): wall seconds of a 50-run dispersed campaign of
    both (:func:`campaign_time`); ``compile_s``: compiling the core from scratch;
    ``main_job_s``: wall time of the default main job over ``duration`` with a warm cache; the chosen steps, the
    degrees of freedom and the machine.
    """
    from postcapture.config.schema import ARCSEC

    say = progress or (lambda msg: None)
    scenario = load_scenario(scenario_name)
    sim = scenario.simulation
    out: dict = {"scenario": scenario_name, "duration_s": duration, "integrator": sim.integrator,
                 "tolerance_rad": sim.tolerance or ARCSEC, "joint_tolerance_rad": BENCH_JOINT_TOLERANCE,
                 "sample_period_s": sim.sample_period}
    say("compile time of the plant core")
    out["compile_s"] = compile_time()
    for n in segments:
        say(f"truth real-time factor, N = {n}")
        r = _rtf(scenario, n, duration, repeats if n < 200 else 1, None)
        out[f"rtf_n{n}"] = r["rtf"]
        out[f"rtf_run_only_n{n}"] = r["rtf_run_only"]
        out[f"step_s_n{n}"] = r["step_s"]
        out[f"n_dof_n{n}"] = r["n_dof"]
    say("truth real-time factor at 1 arcsec, N = 5")
    r = _rtf(scenario, 5, duration, repeats, ARCSEC)
    out["rtf_n5_1arcsec"] = r["rtf"]
    out["step_s_n5_1arcsec"] = r["step_s"]
    for n in (5, 50):
        say(f"prediction with every Jacobian, N = {n}")
        out[f"predict_ms_n{n}"] = _predict_ms(scenario, n)
    est = scenario.estimation
    say("the filters' prediction with every Jacobian, N = 5")
    out["predict_ms_n5_filters"] = _predict_ms(scenario, 5, integrator=est.integrator, step=est.model_step,
                                               dt=est.filter_step)
    for case in ("dual", "joint"):
        say(f"the {case} estimator over {duration:g} s, N = 5")
        out[f"filter_rtf_{case}_n5"] = _filter_rtf(scenario, case, duration)
    if campaign:
        say("a 50-run dispersed campaign of dual and joint")
        out["campaign50_s"] = campaign_time(scenario_name)
    if main_job:
        from postcapture.studies.main_job import run_main_job

        say("main job (default)")
        t0 = time.perf_counter()
        run_main_job(scenario, duration=max(duration, 1.0))  # the main job needs ten filter steps
        out["main_job_s"] = time.perf_counter() - t0
    out["machine"] = machine_info()
    return out
