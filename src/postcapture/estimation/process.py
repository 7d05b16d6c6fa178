"""The ProcessModel protocol: what a filter needs from a plant model, native or FMU.

The filters see a plant only through this interface, so any implementation plugs in: the native
Pinocchio model (:class:`postcapture.dynamics.process_model.NativeProcessModel`) or an FMI
co-simulation unit (:class:`postcapture.fmi.process_model.FMUProcessModel`).

State
-----
``x`` is a flat float vector of length ``nx``; its tangent (error) space has dimension ``n``.
``retract(x, dx)`` and ``local(x1, x0)`` map between them (box-plus / box-minus). The attitude error
(3, body frame, right perturbation) sits at ``tangent_attitude``, the error of the chaser's linear
velocity (body frame) at ``tangent_velocity``, the body-rate error at ``tangent_rate`` and the arm's
joint-angle errors at the indices ``tangent_arm``: what the sensors read (see
:mod:`postcapture.estimation.increments`).

One step
--------
``predict(x, t, dt)`` follows the reference's loop around ``fmi2DoStep``: the corrected state goes in,
the model advances over ``[t, t + dt]`` with the current target mass and its known inputs, and the
predicted state comes out with the measurement predicted there,
``z = [chaser acceleration at the accelerometer (3, body frame), arm joint accelerations (n_arm)]``.
With ``jacobians=True`` it also returns the step Jacobian ``F = d x1 / d x`` (n x n, tangent), its
derivative with respect to the target mass ``g = d x1 / d m`` (n,), the measurement Jacobian
``H = d z / d x1`` (m x n) and ``h = d z / d m`` (m,) at fixed state.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from postcapture.core.prediction import Prediction

__all__ = ["Prediction", "ProcessModel"]


@runtime_checkable
class ProcessModel(Protocol):
    """A plant a filter can propagate and measure (see the module docstring)."""

    name: str
    nx: int
    n: int
    n_meas: int
    tangent_attitude: slice
    tangent_velocity: slice
    tangent_rate: slice
    tangent_arm: np.ndarray
    accelerometer_position: np.ndarray

    @property
    def mass(self) -> float:
        """Target mass used by the model (kg)."""

    @mass.setter
    def mass(self, value: float) -> None: ...

    def copy(self) -> "ProcessModel":
        """An independent copy: filters work on their own copy and never change the caller's model."""

    def initial_state(self) -> np.ndarray:
        """The scenario's initial state ``x0`` (nx,)."""

    def predict(self, x: np.ndarray, t: float, dt: float, jacobians: bool = False) -> Prediction:
        """Advance ``x`` from ``t`` to ``t + dt`` and predict the measurement there."""

    def retract(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """``x (+) dx`` (box-plus) with ``dx`` in tangent coordinates (n,)."""

    def local(self, x1: np.ndarray, x0: np.ndarray) -> np.ndarray:
        """``x1 (-) x0`` (box-minus), shape (n,)."""

    def attitude(self, x: np.ndarray) -> np.ndarray:
        """Chaser attitude ``q_BN`` (scalar first, w >= 0) of a state."""

    def body_rate(self, x: np.ndarray) -> np.ndarray:
        """Chaser body rate ``omega_BN_B`` (rad/s) of a state."""

    def chaser_velocity(self, x: np.ndarray) -> np.ndarray:
        """Velocity of the chaser's origin B (its centre of mass), body components (m/s)."""

    def arm_angles(self, x: np.ndarray) -> np.ndarray:
        """The arm's joint angles (rad) of a state."""
