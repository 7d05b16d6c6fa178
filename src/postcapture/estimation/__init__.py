"""Estimators: one stepper interface, attitude filters, parameter filters, and the schemes composed of them.

The estimators see the plant only through measurements and a process model; this package imports
:mod:`postcapture.core` and nothing else from postcapture (no Pinocchio, no FMPy).

* The interface (:mod:`.filter`): ``predict(t, dt, u)`` / ``update(Measurement)``, a
  :class:`FilterStatus`, :class:`FilterEvent` records, and the recovery policy (:class:`RecoveryPolicy`).
* Filters: the :class:`MEKF` (gyro-driven, model-free), the reference's model-based :class:`AttitudeEKF`
  and sigmoid :class:`MassFilter`, and the :class:`AugmentedEKF` (plant state, sensor biases, the plant's
  parameters estimated or considered, in :class:`ParameterMap` coordinates).
* Schemes: :func:`run_joint_scheme` and :func:`run_dual_scheme` (the recommended configurations) and
  :func:`run_dual` (the reference's dual scheme); :func:`run_mekf` over recorded samples.
* :func:`mass_crlb`: the Cramer-Rao bound of the mass, with or without nuisance parameters.
"""

from postcapture.core.farrenkopf import FarrenkopfSteadyState, farrenkopf_steady_state
from postcapture.estimation.attitude_ekf import AttitudeEKF, AttitudeEKFTuning
from postcapture.estimation.augmented import AugmentedEKF, AugmentedTuning
from postcapture.estimation.crlb import MassCRLB, mass_crlb
from postcapture.estimation.dual import DualConfig, DualResult, SensorSuite, run_dual
from postcapture.estimation.filter import FilterEvent, FilterStatus, Measurement, RecoveryPolicy
from postcapture.estimation.history import EstimateHistory, SampledSignal, StepFlag
from postcapture.estimation.mass_filter import MassFilter, MassFilterTuning
from postcapture.estimation.mekf import MEKF, MEKFTuning, run_mekf
from postcapture.estimation.parameters import GROUPS, ParameterMap
from postcapture.estimation.schemes import SchemeResult, run_dual_scheme, run_joint_scheme

__all__ = [
    "FilterStatus",
    "FilterEvent",
    "Measurement",
    "RecoveryPolicy",
    "MEKF",
    "MEKFTuning",
    "AttitudeEKF",
    "AttitudeEKFTuning",
    "MassFilter",
    "MassFilterTuning",
    "AugmentedEKF",
    "AugmentedTuning",
    "ParameterMap",
    "GROUPS",
    "SensorSuite",
    "DualConfig",
    "DualResult",
    "SchemeResult",
    "run_dual",
    "run_dual_scheme",
    "run_joint_scheme",
    "run_mekf",
    "MassCRLB",
    "mass_crlb",
    "EstimateHistory",
    "StepFlag",
    "SampledSignal",
    "FarrenkopfSteadyState",
    "farrenkopf_steady_state",
]
