"""Resource limits: memory and CPU time a run would need, estimated before anything is allocated.

A run is refused, with a message naming the limit and how to raise it, when its estimate exceeds

* memory: ``POSTCAPTURE_MAX_MEMORY`` (bytes, or with a suffix ``K``, ``M``, ``G``, ``T``: powers of 1024);
  default half of this machine's physical memory;
* CPU time: ``POSTCAPTURE_MAX_CPU_HOURS``; default 24 h.

The estimates are deliberately simple and conservative (they count what dominates):

* the multibody model itself (an instance of the compiled core: its scratch arena for the step
  Jacobians) takes about ``512 nv^2`` bytes (measured: 17 MB of address space at nv = 175);
* a truth simulation keeps ``n_samples = duration / sample_period + 1`` columns of
  ``q, v, ddq`` and the recorded outputs, ``8 (nq + 2 nv + 75)`` bytes each, and its NetCDF file is a
  second copy; each implicit step (SDIRK) factorises dense ``nv x nv`` matrices, about
  ``1e-3 + 1.5e-8 nv^3`` s of CPU, an explicit step (RK4) about ``6e-4 + 8e-7 nv^2`` s. Measured CPU
  per step on the 2-core development machine (shared, so on the high side): SDIRK3 1.4, 118 and 800 ms at
  nv = 25, 215 and 415; RK4 0.57, 29 and 111 ms. The formulas give 1.2, 150 and 1070 ms; 0.6, 38 and
  140 ms;
* the main job adds, per case, about 70 float64 histories over the filter grid and one filter step of
  about 6 truth steps per filter instant; a campaign multiplies that by its runs, and keeps every run's
  histories.

``nv`` follows from the scenario without building the model (:func:`degrees_of_freedom`, checked against
the built model by the tests).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

from postcapture.core.errors import Problem, ResourceLimitError, ScenarioError

__all__ = [
    "MEMORY_VARIABLE",
    "CPU_VARIABLE",
    "Limits",
    "Estimate",
    "degrees_of_freedom",
    "estimate_model",
    "estimate_simulation",
    "truth_step_guess",
    "estimate_run",
    "check_resources",
]

MEMORY_VARIABLE = "POSTCAPTURE_MAX_MEMORY"
CPU_VARIABLE = "POSTCAPTURE_MAX_CPU_HOURS"
_DEFAULT_CPU_HOURS = 24.0
_OUTPUT_ROWS = 75  # recorded outputs per sample (accelerations, momenta, energies, panel tips, ...)
_CASE_ROWS = 70  # float64 histories a filter case keeps per filter instant (attitude, P, mass, NIS, ...)
_FILTER_FACTOR = 50.0  # CPU of one filter instant (prediction with exact Jacobians, dense covariance
# products and updates in Python: about 2.7 ms at 25 DoF) in implicit truth steps
_UNITS = {"": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40}


def _physical_memory() -> float:
    try:
        return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 8.0 * 2**30


def _bytes(amount: float) -> str:
    n, unit = float(amount), "B"
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if abs(n) < 1024 or unit == "EiB":
            break
        n /= 1024
    return f"{n:.3g} {unit}" if math.isfinite(n) else "an unbounded amount"


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "forever"
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("h", 3600), ("min", 60)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


@dataclass(frozen=True)
class Limits:
    """The limits in force: memory (bytes) and CPU time (s), and where each comes from."""

    max_memory: float
    max_cpu_seconds: float
    memory_source: str = "default"
    cpu_source: str = "default"

    @classmethod
    def from_environment(cls, environ=None) -> Limits:
        """Read :data:`MEMORY_VARIABLE` and :data:`CPU_VARIABLE`, or use the defaults.

        Raises
        ------
        ScenarioError
            When a variable is set to something that is not a positive amount.
        """
        env = os.environ if environ is None else environ
        problems = []
        memory, memory_source = _physical_memory() / 2, "half this machine's memory"
        text = env.get(MEMORY_VARIABLE, "").strip()
        if text:
            unit = text[-1].upper() if text[-1].upper() in _UNITS and not text[-1].isdigit() else ""
            number = text[:-1] if unit else text
            try:
                memory = float(number) * _UNITS[unit]
                memory_source = f"{MEMORY_VARIABLE}={text}"
            except ValueError:
                memory = float("nan")
            if not (math.isfinite(memory) and memory > 0):
                problems.append(Problem(MEMORY_VARIABLE, "a positive number of bytes, optionally with K, M, G or T",
                                        repr(text)))
        cpu, cpu_source = _DEFAULT_CPU_HOURS * 3600, f"the default {_DEFAULT_CPU_HOURS:g} h"
        text = env.get(CPU_VARIABLE, "").strip()
        if text:
            try:
                cpu = float(text) * 3600
                cpu_source = f"{CPU_VARIABLE}={text}"
            except ValueError:
                cpu = float("nan")
            if not (math.isfinite(cpu) and cpu > 0):
                problems.append(Problem(CPU_VARIABLE, "a positive number of hours", repr(text)))
        if problems:
            raise ScenarioError(problems, "environment")
        return cls(memory, cpu, memory_source, cpu_source)


@dataclass(frozen=True)
class Estimate:
    """Memory (bytes) and CPU time (s) a piece of work would need, and what drives each."""

    what: str
    memory: float
    cpu_seconds: float
    memory_detail: str = ""
    cpu_detail: str = ""
    hint: str = ""


def degrees_of_freedom(scenario, variant: str = "flexible", panel_segments: int | None = None) -> int:
    """``nv`` of the model :func:`postcapture.dynamics.build.build_system` would build (no building).

    Free flyer (6), then for the ``flexible`` and ``stiff`` variants one per arm joint and Spong rotor and
    ``segments + 1`` per panel (a torsion hinge and one bending hinge per segment); ``rigid`` locks them all.
    """
    if variant == "rigid":
        return 6
    arm = scenario.arm.joints if scenario.arm is not None else ()
    n = 6 + len(arm) + sum(1 for j in arm if j.rotor_inertia is not None)
    for _, panel in scenario.panels():
        n += (panel.segments if panel_segments is None else int(panel_segments)) + 1
    return n


def _samples(duration: float, period: float) -> float:
    ratio = duration / period
    return ratio + 1.0 if math.isfinite(ratio) else math.inf


def _step_cpu(nv: int, integrator: str) -> float:
    # the compiled core's recursions are O(nv) per stage (BENCHMARKS.md: 40-60 us per implicit step at
    # 25 DoF, 0.25 ms at 115, 0.9 ms at 415); an explicit step has fewer stages and no Newton iteration
    if integrator == "rk4":
        return 5e-6 + 4e-7 * nv
    return 1e-5 + 2e-6 * nv


def _model_bytes(nv: int) -> float:
    return 512.0 * nv**2 + 4 * 2**20  # the compiled core's instance: its scratch arena grows as nv^2


def estimate_model(nv: int) -> Estimate:
    """Estimate of building the multibody model of ``nv`` degrees of freedom."""
    return Estimate("building the model", _model_bytes(nv), 0.0,
                    memory_detail=f"{nv} degrees of freedom, the workspace growing as nv^2",
                    hint="use fewer panel segments")


def truth_step_guess(sample_period: float) -> float:
    """The step a truth at its declared accuracy is expected to take, for estimates made before its pilot
    chooses it (s): an eighth of the sample period, at most 1/80 s (what 1 arcsec takes on the default
    scenario)."""
    return min(sample_period, 0.1) / 8.0


def estimate_simulation(*, nv: int, duration: float, step: float, sample_period: float,
                        integrator: str = "sdirk3") -> Estimate:
    """Estimate of one truth simulation of ``nv`` degrees of freedom (see the module text).

    Parameters
    ----------
    nv : int
        Degrees of freedom (``nq = nv + 1``).
    duration, step, sample_period : float
        Seconds.
    integrator : str
        ``"rk4"`` (explicit) or an implicit method.
    """
    samples = _samples(duration, sample_period)
    steps = duration / step
    row = 8.0 * ((nv + 1) + 2 * nv + _OUTPUT_ROWS)
    memory = 2.0 * samples * row + _model_bytes(nv)  # histories and their file copy; the model
    cpu = steps * _step_cpu(nv, integrator) if math.isfinite(steps) else math.inf
    return Estimate(
        "the truth simulation", memory, cpu,
        memory_detail=f"{samples:.3g} samples of {_bytes(row)} ({nv} DoF), twice, and the model",
        cpu_detail=f"{steps:.3g} {integrator} steps at {nv} DoF, about {_duration(_step_cpu(nv, integrator))} each",
        hint="shorten the duration, raise the step or the sample period, or use fewer panel segments",
    )


def estimate_run(scenario, *, duration: float | None = None, n_cases: int = 5, runs: int = 1, workers: int = 2,
                 variant: str = "flexible", panel_segments: int | None = None) -> Estimate:
    """Estimate of the main job (``runs = 1``) or a campaign of ``runs`` runs on ``scenario``.

    The truth uses the scenario's simulation settings (``duration`` overrides its duration); every
    case filters over the scenario's filter grid; each of ``workers`` processes builds its own model.
    """
    sim, est = scenario.simulation, scenario.estimation
    T = sim.duration if duration is None else float(duration)
    nv = degrees_of_freedom(scenario, variant, panel_segments)
    # a truth step chosen from the tolerances is not known before its pilot: truth_step_guess
    truth = estimate_simulation(nv=nv, duration=T, step=sim.step or truth_step_guess(sim.sample_period),
                                sample_period=sim.sample_period, integrator=sim.integrator)
    instants = _samples(T, est.filter_step)
    cases = 8.0 * _CASE_ROWS * instants * n_cases
    memory = truth.memory + cases * (runs + 1) + max(1, workers) * _model_bytes(nv)  # + one model per worker
    model_steps = max(1.0, round(est.filter_step / est.model_step))
    filt = instants * n_cases * _FILTER_FACTOR * model_steps * _step_cpu(nv, est.integrator)
    cpu = runs * (truth.cpu_seconds + filt)
    what = "the main job" if runs == 1 else f"a campaign of {runs} runs"
    return Estimate(
        what, memory, cpu,
        memory_detail=f"{truth.memory_detail}, and {n_cases} case histories of {instants:.3g} instants"
                      + (f" for each of {runs} runs" if runs > 1 else ""),
        cpu_detail=f"{truth.cpu_detail}, then {n_cases} filter cases" + (f", times {runs} runs" if runs > 1 else ""),
        hint="shorten --duration, run fewer cases or runs, or use fewer panel segments",
    )


def check_resources(estimate: Estimate, limits: Limits | None = None) -> Estimate:
    """Raise :class:`ResourceLimitError` when ``estimate`` exceeds a limit; return it otherwise.

    The message names the work, the estimate and what drives it, the limit and where it comes from,
    and how to raise it.
    """
    limits = Limits.from_environment() if limits is None else limits
    if not estimate.memory <= limits.max_memory:
        raise ResourceLimitError(
            f"{estimate.what} would need about {_bytes(estimate.memory)} of memory ({estimate.memory_detail}); "
            f"the limit is {_bytes(limits.max_memory)} ({limits.memory_source}). To go ahead, "
            f"{estimate.hint}, or raise the limit: {MEMORY_VARIABLE}=64G for example",
            "memory", estimate.memory, limits.max_memory)
    if not estimate.cpu_seconds <= limits.max_cpu_seconds:
        raise ResourceLimitError(
            f"{estimate.what} would take about {_duration(estimate.cpu_seconds)} of CPU time "
            f"({estimate.cpu_detail}); the limit is {_duration(limits.max_cpu_seconds)} ({limits.cpu_source}). "
            f"To go ahead, {estimate.hint}, or raise the limit: {CPU_VARIABLE}=100 for example",
            "time", estimate.cpu_seconds, limits.max_cpu_seconds)
    return estimate
