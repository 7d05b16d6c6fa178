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
from postcapture.sensors.joints import measure_joint_accelerations
from postcapture.sensors.profiles import SensorProfile, get_profile
from postcapture.sensors.star_tracker import measure_star_tracker

__all__ = ["resolve_profile", "interval_mean_rate", "measure_all"]


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


def measure_all(traj, profile: SensorProfile, rng: np.random.Generator, faults=()) -> SensorSuite:
    """Every sensor of the profile sampled from a truth trajectory, with an explicit generator.

    ``faults`` (see :mod:`postcapture.config.faults`) are applied after the noise is drawn: the same seed
    gives the same noise with or without them.
    """
    t = traj.t
    records = {
        "star_tracker": measure_star_tracker(profile.star_tracker, t, traj["q_BN"], rng=rng),
        "gyro": measure_gyro(profile.gyro, t, interval_mean_rate(t, traj["q_BN"]), rng=rng),
        "accelerometer": measure_accelerometer(profile.accelerometer, t, traj["accel_B"], rng=rng),
        "joints": measure_joint_accelerations(profile.joints, t, traj["arm_ddq"], rng=rng),
    }
    records = apply_faults(records, faults)
    return SensorSuite(star=records["star_tracker"], gyro=records["gyro"], accel=records["accelerometer"],
                       joints=records["joints"])
