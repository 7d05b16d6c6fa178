"""The main job's estimation cases and how each is configured from the resolved tunings.

Cases: the reference's four dual schemes {EKF, MEKF} x {flexible, stiff (k = 1e7) filter model}, and
the joint EKF on the flexible model. Tunings come from :mod:`postcapture.studies.tuning`:

- ``reference`` profile: the reference's attitude EKF (R = 0.01^2 I3, Q = 0.0007^2 I3, P0 = 0.02^2 I3),
  its mass filter (R_theta = diag(1e-4 I3, 1e-2 I7), q from 20.1 to 0.1, sigmoid c = 0.001, a = 9000,
  b = 5000 for Envisat), a MEKF with the gyro's own noise and the same star-tracker R;
- ``realistic`` profile: every filter's noise matched to the simulated sensors, the mass filter's
  process noise scheduled from 20.1 down to 1e-4 (a constant parameter), and the accelerometer bias
  estimated alongside the mass.

The dual mass filters use the total sensitivity and the state shift by default (see
:mod:`postcapture.estimation.dual`); ``mass_sensitivity="partial"`` gives the reference's own filter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.studies.tuning import ResolvedTuning, sigmoid_prior_variance
from postcapture.core.sigmoid import SigmoidMap
from postcapture.estimation.attitude_ekf import AttitudeEKFTuning
from postcapture.estimation.dual import DualConfig
from postcapture.estimation.mass_filter import MassFilterTuning
from postcapture.estimation.mekf import MEKFTuning
from postcapture.sensors.profiles import SensorProfile

__all__ = ["CaseSpec", "CASES", "DEFAULT_CASES", "RECOMMENDED", "default_cases", "dual_config", "filter_noise"]


@dataclass(frozen=True)
class CaseSpec:
    """One estimation case: scheme, attitude filter, filter-model variant, mass sensitivity."""

    name: str
    scheme: str  # "reference_dual" (attitude filter + sigmoid mass filter), "dual" or "joint" (recommended)
    attitude: str  # "ekf" or "mekf" (reference_dual), "mekf" (dual) or "joint"
    variant: str  # filter model: "flexible", "stiff", "rigid"
    mass_sensitivity: str = "total"
    shift_state: bool = True


CASES = {
    # the recommended configurations (estimation.schemes): consistent when the model is not the truth
    "dual": CaseSpec("dual", "dual", "mekf", "flexible"),
    "joint": CaseSpec("joint", "joint", "joint", "flexible"),
    # the reference's four dual schemes, for comparison
    "ekf_flexible": CaseSpec("ekf_flexible", "reference_dual", "ekf", "flexible"),
    "ekf_stiff": CaseSpec("ekf_stiff", "reference_dual", "ekf", "stiff"),
    "mekf_flexible": CaseSpec("mekf_flexible", "reference_dual", "mekf", "flexible"),
    "mekf_stiff": CaseSpec("mekf_stiff", "reference_dual", "mekf", "stiff"),
    # the reference's own mass filter: derivative at fixed state, no state shift
    "ekf_flexible_partial": CaseSpec("ekf_flexible_partial", "reference_dual", "ekf", "flexible", "partial", False),
    "mekf_flexible_partial": CaseSpec("mekf_flexible_partial", "reference_dual", "mekf", "flexible", "partial", False),
}
DEFAULT_CASES = ("dual", "joint", "ekf_flexible", "ekf_stiff", "mekf_flexible", "mekf_stiff")
RECOMMENDED = ("dual", "joint")


def default_cases(plant: str = "native") -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The default cases for a plant, and those left out: an FMU is one plant, so it runs the cases of the
    flexible model (the recommended ones and the reference's dual schemes), not those of the stiff one."""
    if plant == "native":
        return DEFAULT_CASES, ()
    kept = tuple(c for c in DEFAULT_CASES if CASES[c].variant == "flexible")
    return kept, tuple(c for c in DEFAULT_CASES if c not in kept)


def filter_noise(profile: SensorProfile, tuning: ResolvedTuning, n_arm: int) -> dict:
    """Each sensor's noise covariance as the recommended filters assume it, by measurement kind.

    The gyro's white part of one mean-rate sample, the star tracker's tuning, the accelerometer's
    mean specific force (its velocity random walk over one sample) and each encoder's reading (noise and
    quantisation).
    """
    return {
        "gyro": profile.gyro.sample_sigma**2 * np.eye(3),
        "star_tracker": np.asarray(tuning.star_covariance, dtype=float),
        "accelerometer": profile.accelerometer.sigma**2 * np.eye(3),
        "encoders": profile.joints.sample_sigma**2 * np.eye(n_arm),
    }


def _sigmoid(tuning: ResolvedTuning) -> SigmoidMap:
    lo, hi = tuning.mass_bounds
    return SigmoidMap(a=hi, b=lo, c=tuning.sigmoid_c)


def dual_config(spec: CaseSpec, profile: SensorProfile, profile_name: str, tuning: ResolvedTuning, n_arm: int,
                m0: float) -> DualConfig:
    """The dual scheme of a case under a sensor profile and its resolved tunings; ``m0`` the initial mass (kg)."""
    smap = _sigmoid(tuning)
    R_z = np.concatenate([np.full(3, tuning.mass_accel_sigma**2), np.full(n_arm, tuning.mass_joint_sigma**2)])
    q0, q1 = tuning.mass_process_variance
    common = dict(R_diag=R_z, q_start=q0, q_end=q1, sensitivity=spec.mass_sensitivity, sigmoid=smap,
                  P0=sigmoid_prior_variance(tuning, smap, m0))
    if profile_name == "reference":
        mass = MassFilterTuning(**common)
    else:
        acc = profile.accelerometer
        mass = MassFilterTuning(**common, accel_bias=True, P0_accel_bias=tuning.accelerometer_bias_initial_sigma**2,
                                q_accel_bias=acc.sigma_bias_walk**2 / acc.rate)
    # The realistic EKF's plant copy's rates are not corrected: its attitude drifts with its rate error, which
    # the mass uncertainty sets (mass-aware Q in the dual scheme); the floor (attitude_process_sigma) covers
    # the rest. Over 300 s and 10 seeds, a floor of 2e-7 rad gave a mean NEES of 4.1, 6e-7 gave 2.3, 4e-7 gives 2.6.
    ekf = AttitudeEKFTuning(R=tuning.star_covariance, Q=tuning.attitude_process_sigma**2 * np.eye(3),
                            P0=tuning.attitude_P0, gate_probability=tuning.gate_probability)
    mekf = MEKFTuning(sigma_v=profile.gyro.sigma_v, sigma_u=profile.gyro.sigma_u, star_covariance=tuning.star_covariance,
                      gate_probability=tuning.gate_probability, name=f"{spec.name}/mekf")
    calibrated = tuning.gyro_scale_sigma > 0 or tuning.gyro_misalignment_sigma > 0
    mekf_P0 = np.zeros((15, 15) if calibrated else (6, 6))
    mekf_P0[:3, :3] = tuning.attitude_P0
    mekf_P0[3:6, 3:6] = tuning.gyro_bias_initial_sigma**2 * np.eye(3)
    if calibrated:  # the gyro's scale factors and misalignments (section 6.4.1 of Markley and Crassidis)
        mekf_P0[6:, 6:] = np.diag([tuning.gyro_scale_sigma**2] * 3 + [tuning.gyro_misalignment_sigma**2] * 6)
    return DualConfig(spec.attitude, mass, ekf=ekf, mekf=mekf, mekf_P0=mekf_P0, shift_state=spec.shift_state,
                      mass_aware_q=(profile_name != "reference" and spec.mass_sensitivity == "total"), name=spec.name)
