"""Scheduled sensor faults (``[[faults]]``): applied to the truth-side sensors; the filters are not told.

Kinds (times in s, steps in SI):

- ``star_tracker_outage``, ``gyro_outage``, ``accelerometer_outage``: no samples on ``[start, stop)``;
- ``gyro_bias_step`` (rad/s), ``accelerometer_bias_step`` (m/s^2): the bias jumps by ``step`` (3, body
  axes) at ``time`` and stays;
- ``accelerometer_scale_step``: the scale-factor errors of the three axes jump by ``step`` (relative:
  1e-3 is 1000 ppm) at ``time`` (0 for the whole run) and stay;
- ``joint_stuck``: joint ``joint``'s sensor repeats its last sample before ``start`` on
  ``[start, stop)``; ``joint_dropout``: it gives no samples there.

``stop`` defaults to the end of the run.
"""

from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import Field, model_validator

from postcapture.config.types import Frozen, Instant, Vec3, problem

__all__ = ["Outage", "BiasStep", "JointFault", "Fault", "FAULT_KINDS", "STEP_LIMITS", "fault_window"]

STEP_LIMITS = {"gyro_bias_step": (0.01, "rad/s"), "accelerometer_bias_step": (1.0, "m/s^2"),
               "accelerometer_scale_step": (0.1, "(relative)")}
"""Largest bias step per axis: 0.01 rad/s is 2000 deg/h, 1 m/s^2 a tenth of a g; no sensor that jumps further
is a sensor with a bias."""


class _Window(Frozen):
    """A fault on a window of time.

    Attributes
    ----------
    start, stop : float
        The window ``[start, stop)`` (s); without ``stop`` the fault lasts to the end of the run.
    time : float
        When a bias step happens (s).
    step : list of 3 float
        A bias step, body axes (rad/s for the gyro, m/s^2 for the accelerometer).
    joint : int
        The arm joint (1-based) whose sensor fails.
    """

    start: Instant
    stop: Instant | None = None

    @model_validator(mode="after")
    def _order(self):
        if self.stop is not None and self.stop <= self.start:
            raise problem(f"stop > start = {self.start}", self.stop)
        return self


class Outage(_Window):
    """A sensor gives no samples on ``[start, stop)``."""

    kind: Literal["star_tracker_outage", "gyro_outage", "accelerometer_outage"]


class BiasStep(Frozen):
    """A bias jump of ``step`` (body axes; rad/s or m/s^2) at ``time``, or a jump of the accelerometer's
    scale-factor errors (relative).

    Attributes
    ----------
    time : float
        When the bias jumps (s).
    step : list of 3 float
        The jump, body axes (rad/s for the gyro, m/s^2 for the accelerometer, relative for a scale factor).
    """

    kind: Literal["gyro_bias_step", "accelerometer_bias_step", "accelerometer_scale_step"]
    time: Instant
    step: Vec3 = Field(json_schema_extra={"unit": "rad/s, m/s^2 or 1", "limit": "0.01 rad/s (gyro), 1 m/s^2 "
                                                                                 "(accelerometer), 0.1 (scale factor)"})

    @model_validator(mode="after")
    def _physical(self):
        limit, unit = STEP_LIMITS[self.kind]
        if max(abs(x) for x in self.step) > limit:
            raise problem(f"a bias step of at most {limit:g} {unit} per axis", list(self.step), field="step")
        return self


class JointFault(_Window):
    """Joint ``joint`` (1-based) sensor stuck at its last value, or silent, on ``[start, stop)``."""

    kind: Literal["joint_stuck", "joint_dropout"]
    joint: int = Field(ge=1, le=1000)


Fault = Annotated[Union[Outage, BiasStep, JointFault], Field(discriminator="kind")]
FAULT_KINDS = ("star_tracker_outage", "gyro_outage", "accelerometer_outage", "gyro_bias_step",
               "accelerometer_bias_step", "accelerometer_scale_step", "joint_stuck", "joint_dropout")


def fault_window(fault) -> tuple[float, float | None]:
    """``(start, stop)`` of a fault (a bias step starts at its time and never stops)."""
    if isinstance(fault, BiasStep):
        return fault.time, None
    return fault.start, fault.stop
