"""From a truth trajectory and a sensor profile to the measurements the filters read."""

from __future__ import annotations

import dataclasses

import numpy as np

from postcapture.config.schema import Scenario
from postcapture.core import rotations as rot
from postcapture.estimation.dual import SensorSuite
from postcapture.sensors.accelerometer import measure_accelerometer
from postcapture.sensors.faults import apply_faults
from postcapture.sensors.gyroscope import measure_gyro
from postcapture.sensors.joints import measure_joint_angles
from postcapture.sensors.profiles import SensorProfile, get_profile
from postcapture.sensors.star_tracker import measure_star_tracker

__all__ = ["resolve_profile", "noiseless", "interval_mean_rate", "interval_mean_specific_force", "measure_all"]


def resolve_profile(scenario: Scenario, name: str) -> SensorProfile:
    """A built-in sensor profile with the scenario's overrides (``[estimation.sensors.<name>]``) applied."""
    profile = get_profile(name)
    spec = scenario.estimation.sensors.get(name)
    if spec is None:
        return profile
    changes = {}
    for field in ("star_tracker", "gyro", "accelerometer", "joints"):
        overrides = {k: (np.asarray(v, dtype=float) if isinstance(v, tuple) else v)
                     for k, v in getattr(spec, field).model_dump(exclude_none=True).items()}
        if overrides:
            changes[field] = dataclasses.replace(getattr(profile, field), **overrides)
    return dataclasses.replace(profile, **changes)


def noiseless(profile: SensorProfile) -> SensorProfile:
    """The same sensors without noise, bias, calibration errors, quantisation or dropouts: exact readings."""
    zero3, zero33 = np.zeros(3), np.zeros((3, 3))
    return dataclasses.replace(
        profile,
        star_tracker=dataclasses.replace(profile.star_tracker, sigma_cross=0.0, sigma_roll=0.0, dropout_probability=0.0),
        gyro=dataclasses.replace(profile.gyro, sigma_v=0.0, sigma_u=0.0, initial_bias_B=zero3, scale_factor=zero3,
                                 misalignment=zero33, dropout_probability=0.0),
        accelerometer=dataclasses.replace(profile.accelerometer, sigma=0.0, bias_B=zero3, sigma_bias_walk=0.0,
                                          scale_factor=zero3, misalignment=zero33, dropout_probability=0.0),
        joints=dataclasses.replace(profile.joints, sigma=0.0, resolution=0.0, dropout_probability=0.0),
    )


def interval_mean_rate(t: np.ndarray, q_BN: np.ndarray) -> np.ndarray:
    """Mean body rate over each sample interval, ``box_minus(q_k+1, q_k) / dt`` (3, n).

    A rate-integrating gyro outputs delta-angles; the sample at ``t_k`` stands for ``[t_k, t_k+1]``.
    The last sample repeats the previous interval's rate.
    """
    dt = np.diff(t)
    w = np.empty((3, t.size))
    w[:, :-1] = rot.box_minus(q_BN[:, 1:], q_BN[:, :-1]) / dt
    w[:, -1] = w[:, -2]
    return w


def interval_mean_specific_force(t: np.ndarray, q_BN: np.ndarray, v_B: np.ndarray, omega_BN_B: np.ndarray,
                                 r_B) -> np.ndarray:
    """Mean specific force over each sample interval at the point ``r_B`` of B, ``delta_v_k / dt`` (3, n).

    ``delta_v_k`` is the sensor point's velocity change in N over ``[t_k, t_k+1]`` in the body frame at
    ``t_k`` (:func:`postcapture.estimation.increments.mean_specific_force`): exact from the states at the
    two sample instants. The last sample repeats the previous interval's.

    Parameters
    ----------
    t : ndarray (n,)
    q_BN : ndarray (4, n)
    v_B, omega_BN_B : ndarray (3, n)
        Velocity of B's origin and body rate, body components (m/s, rad/s).
    r_B : array_like (3,)
        The sensor's position in B (m).
    """
    from postcapture.estimation.increments import mean_specific_force

    r = np.asarray(r_B, dtype=float)
    out = np.empty((3, t.size))
    phi = rot.box_minus(q_BN[:, 1:], q_BN[:, :-1])
    for k in range(t.size - 1):
        out[:, k] = mean_specific_force(phi[:, k], v_B[:, k], omega_BN_B[:, k], v_B[:, k + 1],
                                        omega_BN_B[:, k + 1], r, t[k + 1] - t[k])[0]
    out[:, -1] = out[:, -2]
    return out


def measure_all(traj, profile: SensorProfile, rng: np.random.Generator, faults=(), *,
                accelerometer_position=(0.0, 0.0, 0.0), mean_motion: float = 0.0) -> SensorSuite:
    """Every sensor of the profile sampled from a truth trajectory, with an explicit generator.

    The gyro and the accelerometer output increments over each sample period (mean rate and mean
    specific force at ``accelerometer_position`` in B, m, less the tidal field of an orbit of
    ``mean_motion`` rad/s); the joints' encoders their angles.

    ``faults`` (see :mod:`postcapture.config.faults`) are applied after the noise is drawn: the same seed
    gives the same noise with or without them.
    """
    t = traj.t
    f_B = interval_mean_specific_force(t, traj["q_BN"], traj.v[0:3], traj.v[3:6], accelerometer_position)
    if mean_motion:  # in orbit the accelerometer reads the acceleration less the tidal field
        from postcapture.estimation.increments import tidal_mean_B0

        q, r = traj["q_BN"], traj["r_BN_N"]
        for k in range(t.size - 1):
            f_B[:, k] -= tidal_mean_B0(q[:, k], r[:, k], q[:, k + 1], r[:, k + 1], accelerometer_position,
                                       mean_motion, t[k], t[k + 1])
        f_B[:, -1] = f_B[:, -2]
    records = {
        "star_tracker": measure_star_tracker(profile.star_tracker, t, traj["q_BN"], rng=rng),
        "gyro": measure_gyro(profile.gyro, t, interval_mean_rate(t, traj["q_BN"]), rng=rng),
        "accelerometer": measure_accelerometer(profile.accelerometer, t, f_B, rng=rng),
        "joints": measure_joint_angles(profile.joints, t, traj["arm_q"], rng=rng),
    }
    records = apply_faults(records, faults)
    return SensorSuite(star=records["star_tracker"], gyro=records["gyro"], accel=records["accelerometer"],
                       joints=records["joints"])
