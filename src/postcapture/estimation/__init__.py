"""Estimators: attitude filters, the constrained mass filter, dual and joint schemes.

The estimators see the plant only through measurements and a process model; this package imports
:mod:`postcapture.core` and nothing else from postcapture (no Pinocchio, no FMPy).

Available so far:

* :func:`run_mekf` over the :class:`MEKF` stepper, tuned by :class:`MEKFTuning`: the
  Lefferts-Markley-Shuster multiplicative EKF, gyro-driven, error state attitude (3) + gyro bias (3).
* :class:`EstimateHistory` and :class:`StepFlag`: the record every attitude filter returns;
  :class:`SampledSignal`: what filters read from a sensor record.
* :func:`farrenkopf_steady_state`: the analytic steady-state accuracy the MEKF is judged against.
"""

from postcapture.core.farrenkopf import FarrenkopfSteadyState, farrenkopf_steady_state
from postcapture.estimation.history import EstimateHistory, SampledSignal, StepFlag
from postcapture.estimation.mekf import MEKF, MEKFTuning, run_mekf

__all__ = [
    "EstimateHistory",
    "StepFlag",
    "MEKF",
    "MEKFTuning",
    "SampledSignal",
    "run_mekf",
    "FarrenkopfSteadyState",
    "farrenkopf_steady_state",
]
