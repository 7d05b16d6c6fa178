"""The result of one process-model step, shared by every plant implementation and the filters.

It lives in ``core`` so that plants (``dynamics``, ``fmi``) and filters (``estimation``) can all use it
without importing each other; the protocol itself is :class:`postcapture.estimation.process.ProcessModel`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Prediction"]


@dataclass
class Prediction:
    """One predicted step at time ``t + dt``.

    Attributes
    ----------
    x : ndarray, shape (nx,)
        Predicted state.
    z : ndarray, shape (m,)
        Predicted measurement ``[accel_B (3), arm_ddq (n_arm)]``.
    F : ndarray, shape (n, n), optional
        Step Jacobian in tangent coordinates.
    g : ndarray, shape (n,), optional
        Derivative of the predicted state with respect to the target mass.
    H : ndarray, shape (m, n), optional
        Measurement Jacobian at the predicted state.
    h : ndarray, shape (m,), optional
        Derivative of the measurement with respect to the target mass at fixed state.
    G : ndarray, shape (n, n_p), optional
        Derivative of the predicted state with respect to the model's parameter vector (its
        ``param_names``).
    Hp : ndarray, shape (m, n_p), optional
        Derivative of the measurement with respect to the parameter vector at fixed state.
    """

    x: np.ndarray
    z: np.ndarray
    F: np.ndarray | None = None
    g: np.ndarray | None = None
    H: np.ndarray | None = None
    h: np.ndarray | None = None
    G: np.ndarray | None = None
    Hp: np.ndarray | None = None
