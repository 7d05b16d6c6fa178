"""Known excitation inputs: time profiles on named input channels.

The input vector of the plant is ``u = [F_B (3), tau_B (3), tau_arm (n_arm)]``: a force on the chaser
at its centre of mass and a torque, both in chaser body components (thrusters), then the arm joint
motor torques. Channels are named ``force_x``, ``torque_z``, ``joint_1`` ... ``joint_n``.

Profiles are pure functions of time; entries on the same channel add up. The classes here are the
validated data of the profiles and document their formulas; the formulas exist once, in the compiled
core's C code (``dynamics/csrc/pc_dynamics.c``), and are evaluated through
:class:`postcapture.dynamics.excitation.InputSchedule` (packed by
:func:`postcapture.dynamics.excitation.pack_profiles`).
"""

from __future__ import annotations

import re
from typing import Annotated, Literal, Union

import numpy as np
from pydantic import Field, model_validator

from postcapture.config.types import Angle, Frequency, Frozen, Instant, quantity, problem

Load = quantity("N or N m", ge=-1.0e6, le=1.0e6)
"""A force (N) or a torque (N m), by channel."""

__all__ = ["Step", "Sine", "Chirp", "Table", "Excitation", "CHASER_CHANNELS", "channel_index"]

CHASER_CHANNELS = ("force_x", "force_y", "force_z", "torque_x", "torque_y", "torque_z")
_JOINT = re.compile(r"joint_([1-9][0-9]*)", re.ASCII)  # ASCII digits only: int() would read any Unicode digit


def _joint_number(channel: str) -> int | None:
    """``k`` of a channel named ``joint_<k>`` (k >= 1 in ASCII digits), else None."""
    m = _JOINT.fullmatch(channel)
    return int(m.group(1)) if m else None


def channel_index(channel: str, n_arm: int) -> int:
    """Index of a named channel in the input vector ``u`` (length ``6 + n_arm``)."""
    if channel in CHASER_CHANNELS:
        return CHASER_CHANNELS.index(channel)
    k = _joint_number(channel)
    if k is not None and k <= n_arm:
        return 5 + k
    raise ValueError(f"unknown channel {channel!r}")


class _Window(Frozen):
    """A profile on ``channel``, active on ``[start, stop)`` (``stop`` None: never stops), zero outside;
    the left limit at a switch (``(start, stop]``) is what an integrator sees at the end of a step.

    Attributes
    ----------
    channel : str
        ``force_x|y|z`` (N, on the chaser at its centre of mass, B components), ``torque_x|y|z`` (N m, B
        components) or ``joint_<k>`` (N m, the k-th arm joint's motor).
    start, stop : float
        The window (s); without ``stop`` the profile runs to the end.
    amplitude : float
        N or N m, by channel.
    rise_time : float
        A step's linear ramp up after ``start`` and down before ``stop`` (s).
    frequency : float
        A sine's frequency (Hz).
    phase : float
        Phase at ``start`` (rad).
    offset : float
        Added to a sine (N or N m).
    f0, f1 : float
        A chirp's frequencies at ``start`` and ``stop`` (Hz).
    t, value : list of float
        A table's times (s, increasing) and values (N or N m).
    """

    channel: str = Field(max_length=64)
    start: Instant = 0.0
    stop: Instant | None = None

    @model_validator(mode="after")
    def _window(self):
        if self.stop is not None and self.stop <= self.start:
            raise problem(f"stop > start = {self.start}", self.stop)
        if self.channel not in CHASER_CHANNELS and _joint_number(self.channel) is None:
            raise problem("a channel among force_x|y|z, torque_x|y|z, joint_<k>", repr(self.channel))
        return self


class Step(_Window):
    """Constant ``amplitude`` on ``[start, stop)`` (a pulse when ``stop`` is given).

    With ``rise_time > 0`` the value ramps linearly from 0 over ``rise_time`` after ``start`` and back
    to 0 over ``rise_time`` before ``stop`` (thrust build-up and tail-off), a trapezoid.
    """

    kind: Literal["step"]
    amplitude: Load
    rise_time: quantity("s", ge=0.0, le=1.0e6) = 0.0


class Sine(_Window):
    """``offset + amplitude sin(2 pi frequency (t - start) + phase)`` on ``[start, stop)``."""

    kind: Literal["sine"]
    amplitude: Load
    frequency: Frequency
    phase: Angle = 0.0
    offset: Load = 0.0


class Chirp(_Window):
    """Linear sine sweep from ``f0`` to ``f1`` (Hz) over ``[start, stop)``; ``stop`` is required.

    ``amplitude sin(2 pi (f0 tau + rate tau^2 / 2) + phase)``, ``tau = t - start``,
    ``rate = (f1 - f0) / (stop - start)``.
    """

    kind: Literal["chirp"]
    amplitude: Load
    f0: Frequency
    f1: Frequency
    phase: Angle = 0.0

    @model_validator(mode="after")
    def _needs_stop(self):
        if self.stop is None:
            raise problem("a stop time for a chirp", "none")
        return self


class Table(_Window):
    """Piecewise-linear table ``(t, value)``; constant extrapolation outside, zero outside the window."""

    kind: Literal["table"]
    t: tuple[Instant, ...] = Field(min_length=2, max_length=100_000)
    value: tuple[Load, ...] = Field(min_length=2, max_length=100_000)

    @model_validator(mode="after")
    def _table(self):
        if len(self.t) != len(self.value):
            raise problem(f"as many values as times ({len(self.t)})", len(self.value))
        if np.any(np.diff(self.t) <= 0.0):
            raise problem("strictly increasing times", list(self.t))
        return self


Excitation = Annotated[Union[Step, Sine, Chirp, Table], Field(discriminator="kind")]
