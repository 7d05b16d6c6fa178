"""Accuracy as a setting: the truth's step from a tolerance on the attitude and the joint angles.

:func:`choose_step` controls the global error of a run on a pilot window: it runs the first ``pilot``
seconds at ``h = sample_period / 2^k`` (same method, the compiled core), estimates the error of the run
at ``h`` from the pair ``(2h, h)`` by Richardson's formula ``e(h) = |x_2h - x_h| / (2^p - 1)`` on the
attitude (the rotation angle between the two runs) and on the joint angles, extrapolates it linearly
in time to the whole run, and returns the largest ``h`` whose estimate is within the tolerances. The
steps divide the sample period, so outputs stay on the sample grid.

A tolerance-driven truth accepts Newton's iterations at :func:`newton_for` its tolerance (for 1 arcsec:
about 1e-6 relative and 1e-9 absolute, against the core's default 1e-10 and 1e-15), which makes the run
about 1.6x faster for a negligible change of its error.

An explicit method (RK4) is stable only below the plant's stability limit
(:mod:`postcapture.dynamics.stability`); the halving then starts from the first step below it. The
errors measured against RK4 at 0.25 ms over the default 300 s run are in BENCHMARKS.md (SDIRK4 at
0.025 s: 0.10 arcsec, converging at order 4 with the step).
"""

from __future__ import annotations

import logging

import numpy as np

from postcapture.core.rotations import quat_from_pinocchio, rotation_angle
from postcapture.dynamics.system import System

__all__ = ["choose_step", "newton_for", "PILOT_S"]

logger = logging.getLogger(__name__)

PILOT_S = 30.0
MAX_FIRST_STEP = 0.1  # s


def newton_for(tolerance: float) -> tuple[float, float]:
    """Newton acceptance ``(rtol, atol)`` of a truth run at an attitude ``tolerance`` (rad)."""
    return min(1e-6, 0.2 * tolerance), min(1e-9, 2e-4 * tolerance)


def _run(system: System, q0, v0, method: str, h: float, sample_period: float, duration: float, newton):
    from postcapture.dynamics.core import CompiledPlant

    per = int(round(sample_period / h))
    n = int(round(duration / sample_period)) + 1
    plant = CompiledPlant(system, method)
    plant.set_newton(*newton)
    return plant.simulate(q0, v0, 0.0, h, per, n, sample_period=sample_period)["q"]


def _mean_rates(q_BN: np.ndarray, period: float) -> np.ndarray:
    """Body rates averaged over each sample interval, ``box_minus(q_k+1, q_k) / period`` (3, n - 1)."""
    from postcapture.core.rotations import box_minus

    return box_minus(q_BN[:, 1:], q_BN[:, :-1]) / period


def _first_step(system: System, q0, v0, method: str, sample_period: float, max_halvings: int) -> float:
    """``sample_period / 2^k`` for the smallest k at which the method is stable and the step no longer than
    ``MAX_FIRST_STEP`` (an implicit stage's Newton iteration is well-posed there)."""
    from postcapture.dynamics.core import CompiledPlant
    from postcapture.dynamics.stability import StepTooLargeError, stability_limit

    limit, _ = stability_limit(CompiledPlant(system, method), q0, v0)
    h = sample_period
    while h > MAX_FIRST_STEP:
        h /= 2
    for _ in range(max_halvings + 1):
        if h <= limit:
            return h
        h /= 2
    raise StepTooLargeError(f"step: {method} needs a step <= {limit:.4g} s on this model, below the "
                            f"{max_halvings} halvings of the sample period {sample_period} s that choose_step tries: "
                            "use an L-stable method (sdirk4)", step=h, limit=limit)


def choose_step(
    system: System,
    q0,
    v0,
    *,
    duration: float,
    sample_period: float,
    tolerance: float,
    joint_tolerance: float | None = None,
    rate_tolerance: float | None = None,
    method: str = "sdirk4",
    pilot: float = PILOT_S,
    max_halvings: int = 8,
) -> float:
    """The largest step ``sample_period / 2^k`` whose estimated error over ``duration`` is within ``tolerance``.

    Parameters
    ----------
    system : System
    q0, v0 : ndarray
        Initial state (nq,), (nv,).
    duration, sample_period : float
        The run (s); the pilot covers ``min(pilot, duration)`` seconds.
    tolerance : float
        Largest error of the attitude over the run (rad).
    joint_tolerance : float, optional
        Largest error of every joint angle over the run (rad); None: not controlled.
    rate_tolerance : float, optional
        Largest error of the body rate averaged over each sample period, ``box_minus(q_k+1, q_k) / T``
        (rad/s: what a rate-integrating gyro reads), over the run; None: not controlled.
    method : str
        Integrator (its order enters Richardson's formula).
    max_halvings : int
        Steps tried: ``sample_period / 2^k`` for ``k = 0 .. max_halvings``.

    Returns
    -------
    float
        The step (s).
    """
    from postcapture.dynamics.integrators import TABLEAUX

    if not tolerance > 0:
        raise ValueError(f"tolerance: expected a positive angle in rad, found {tolerance}")
    p = TABLEAUX[method].order
    h_first = _first_step(system, q0, v0, method, sample_period, max_halvings)
    window = min(pilot, duration)
    window = max(sample_period, round(window / sample_period) * sample_period)
    off = system.nq - system.nv
    newton = newton_for(tolerance)
    coarse = _run(system, q0, v0, method, h_first, sample_period, window, newton)
    h = h_first
    for _ in range(max_halvings):
        h /= 2
        fine = _run(system, q0, v0, method, h, sample_period, window, newton)
        q_c, q_f = quat_from_pinocchio(coarse[:, 3:7].T), quat_from_pinocchio(fine[:, 3:7].T)
        att = rotation_angle(q_c, q_f).max()
        joints = np.abs(coarse[:, off + system.n_root_v:] - fine[:, off + system.n_root_v:]).max(initial=0.0)
        rates = np.abs(_mean_rates(q_c, sample_period) - _mean_rates(q_f, sample_period)).max(initial=0.0)
        scale = max(1.0, duration / window) / (2**p - 1)
        err_att, err_joint, err_rate = att * scale, joints * scale, rates * scale
        logger.info("accuracy: %s h = %.6g s, estimated errors over %.0f s: attitude %.3g rad, joints %.3g rad, "
                    "mean rates %.3g rad/s", method, h, duration, err_att, err_joint, err_rate)
        if (err_att <= tolerance and (joint_tolerance is None or err_joint <= joint_tolerance)
                and (rate_tolerance is None or err_rate <= rate_tolerance)):
            return h
        coarse = fine
    return h
