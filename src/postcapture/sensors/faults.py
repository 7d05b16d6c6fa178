"""Scheduled sensor faults applied to recorded measurements (the truth side; filters are not told).

A fault is any object with a ``kind`` and, by kind (see :mod:`postcapture.config.faults`):
``start``/``stop`` (s, ``stop`` None for the end of the run) for outages and joint faults, ``joint``
(1-based) for joint faults, ``time`` (s) and ``step`` (3, SI; relative for a scale factor) for steps. Faults are applied after
the noise is drawn, so a fault schedule never changes the noise of the samples it leaves alone.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from postcapture.sensors.record import Measurements

__all__ = ["apply_faults", "SENSOR_OF_FAULT"]

SENSOR_OF_FAULT = {
    "star_tracker_outage": "star_tracker",
    "gyro_outage": "gyro",
    "accelerometer_outage": "accelerometer",
    "gyro_bias_step": "gyro",
    "accelerometer_bias_step": "accelerometer",
    "accelerometer_scale_step": "accelerometer",
    "joint_stuck": "joints",
    "joint_dropout": "joints",
}


def _window(t: np.ndarray, start: float, stop: float | None) -> np.ndarray:
    on = t >= start
    if stop is not None:
        on &= t < stop
    return on


def _apply(rec: Measurements, fault) -> Measurements:
    values = rec.values.copy()
    valid = rec.valid.copy()
    truth = dict(rec.truth)
    kind = fault.kind
    if kind.endswith("_outage"):
        on = _window(rec.t, fault.start, fault.stop)
        values[:, on] = np.nan
        valid[on] = False
    elif kind.endswith("_scale_step"):  # the readings' scale changes: the true quantity times the step
        on = rec.t >= fault.time
        values[:, on] += np.asarray(fault.step, dtype=float)[:, None] * truth["f_B"][:, on]
    elif kind.endswith("_bias_step"):
        on = rec.t >= fault.time
        step = np.asarray(fault.step, dtype=float)[:, None]
        values[:, on] += step
        if "bias_B" in truth:
            bias = truth["bias_B"].copy()
            bias[:, on] += step
            truth["bias_B"] = bias
    else:  # joint_stuck, joint_dropout
        row = fault.joint - 1
        on = _window(rec.t, fault.start, fault.stop)
        if kind == "joint_dropout":
            values[row, on] = np.nan
        else:
            before = np.nonzero((rec.t < fault.start) & np.isfinite(values[row]))[0]
            values[row, on] = values[row, before[-1]] if before.size else np.nan
    return dataclasses.replace(rec, values=values, valid=valid, truth=truth)


def apply_faults(records: dict[str, Measurements], faults) -> dict[str, Measurements]:
    """Sensor records (by name: star_tracker, gyro, accelerometer, joints) with the faults applied, in order."""
    out = dict(records)
    for fault in faults:
        name = SENSOR_OF_FAULT[fault.kind]
        out[name] = _apply(out[name], fault)
    return out
