"""Hot-call timings of an FMU-backed process model against the native one (for benchmarks and reports)."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from postcapture.config.schema import Scenario

__all__ = ["time_calls", "hot_call_timing"]


def time_calls(fn, repeats: int) -> float:
    """Median wall time of ``fn()`` over ``repeats`` calls after one warm-up call (s)."""
    fn()
    samples = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - t0)
    return float(np.median(samples))


def hot_call_timing(
    fmu_path: str | Path,
    scenario: Scenario,
    *,
    variant: str = "flexible",
    panel_segments: int | None = None,
    t: float = 25.0,
    dt: float = 0.1,
    repeats: int = 50,
) -> dict:
    """Per-call times (us) of the hot FMI calls and of ``predict`` on the FMU and on the native model.

    Parameters
    ----------
    fmu_path : str or Path
        An FMU exported from ``scenario`` (with its mapping).
    scenario : Scenario
        The scenario for the native process model.
    variant, panel_segments :
        As the FMU was exported.
    t, dt : float
        Prediction time and step (s).
    repeats : int
        Calls per measurement (the median is kept).

    Returns
    -------
    dict
        ``getreal_fmpy_100_us`` and ``getreal_raw_100_us`` (100 variables through FMPy's list-converting
        wrapper and through the preallocated buffer), ``fmu_predict_us``, ``fmu_predict_jac_us``,
        ``native_predict_us``, ``native_predict_jac_us`` and the ``jacobian_method``.
    """
    from postcapture.dynamics.build import build_system
    from postcapture.dynamics.process_model import NativeProcessModel
    from postcapture.fmi.process_model import FMUProcessModel
    from postcapture.fmi.slave import Buffer

    system = build_system(scenario, variant, panel_segments=panel_segments)
    native = NativeProcessModel(system, scenario.estimation.model_step, scenario.estimation.integrator)
    out: dict = {}
    with FMUProcessModel(fmu_path) as model:
        x = model.initial_state()
        vrs = [v.valueReference for v in model.model_description.modelVariables][:100]
        buf = Buffer(vrs)
        out["getreal_fmpy_100_us"] = 1e6 * time_calls(lambda: model.slave.fmu.getReal(vrs), repeats * 20)
        out["getreal_raw_100_us"] = 1e6 * time_calls(lambda: model.slave.get_real(buf), repeats * 20)
        out["fmu_predict_us"] = 1e6 * time_calls(lambda: model.predict(x, t, dt), repeats)
        out["fmu_predict_jac_us"] = 1e6 * time_calls(lambda: model.predict(x, t, dt, jacobians=True), repeats)
        out["jacobian_method"] = model.jacobian_method
    out["native_predict_us"] = 1e6 * time_calls(lambda: native.predict(x, t, dt), repeats)
    out["native_predict_jac_us"] = 1e6 * time_calls(lambda: native.predict(x, t, dt, jacobians=True), repeats)
    return out
