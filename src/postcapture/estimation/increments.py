r"""What the chaser's inertial sensors output over one filter cycle, as functions of the states at its ends.

A rate-integrating gyro and a navigation accelerometer output increments over each sample period
``[t_k, t_k+1]`` (see :mod:`postcapture.sensors.gyroscope` and :mod:`postcapture.sensors.accelerometer`):

- the angle increment, the rotation vector from the body frame at ``t_k`` to that at ``t_k+1``,
  ``phi = box_minus(q_k+1, q_k)``, reported as the mean rate ``phi / dt``;
- the velocity increment of the sensor's point in the body frame at ``t_k``,
  ``dv = C_{B_k N} (v_N(t_k+1) - v_N(t_k)) = Exp(phi) u_k+1 - u_k`` with ``u = v_B + omega x r`` the
  sensor point's velocity in body components, reported as the mean specific force ``dv / dt``.

Both are exact functions of the chaser's attitude and twist at the two ends of the cycle (no quadrature:
the integral of an acceleration is a velocity change), so a filter predicts them from its state at
``t_k`` (a clone) and its prediction at ``t_k+1`` with exact Jacobians. (Gravity-gradient specific force,
when the orbit is modelled, adds its own integral; it is below a thousandth of the noise here.)

Perturbations are right perturbations of each attitude (``q (+) d``) and additive on the twists. The
arithmetic is the compiled engine's (``dynamics/csrc/pc_increments.c``), which the filters run; these are
its Python entry points. So is the filters' model of a triad's calibration (scale factors and misalignments,
:mod:`postcapture.core.triad`).
"""

from __future__ import annotations

import numpy as np

from postcapture.dynamics import engine as _engine

__all__ = ["mean_rate", "mean_specific_force", "tidal_mean_B0", "calibration_matrix", "calibration_sensitivity"]

_JACOBIANS = ("att1", "att0", "v1", "w1", "v0", "w0")


def _v3(a) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=float)


def mean_rate(q0_BN, q1_BN, dt: float):
    """The mean body rate over a cycle ``phi / dt`` and its Jacobians (computed by the engine, ``pc_increments.c``).

    Returns
    -------
    z : ndarray (3,)
        ``box_minus(q1, q0) / dt`` (rad/s).
    H1, H0 : ndarray (3, 3)
        Derivatives with respect to the attitude errors at the end and at the start of the cycle.
    phi : ndarray (3,)
        The rotation vector (rad).
    """
    z, H1, H0, phi = np.zeros(3), np.zeros((3, 3)), np.zeros((3, 3)), np.zeros(3)
    _engine.engine().mean_rate(_v3(q0_BN), _v3(q1_BN), float(dt), z, H1, H0, phi)
    return z, H1, H0, phi


def mean_specific_force(phi, v0_B, w0_B, v1_B, w1_B, r_B, dt: float):
    """The sensor point's mean specific force over a cycle, ``(Exp(phi) u1 - u0) / dt``, and its Jacobians.

    Computed by the engine (``pc_increments.c``), the filters' own measurement model.

    Parameters
    ----------
    phi : ndarray (3,)
        Rotation vector from the body frame at the start to that at the end (``box_minus(q1, q0)``).
    v0_B, w0_B, v1_B, w1_B : ndarray (3,)
        Linear velocity of B's origin and body rate, body components, at the start and at the end (m/s, rad/s).
    r_B : ndarray (3,)
        The sensor's position in B (m).
    dt : float
        The cycle (s).

    Returns
    -------
    z : ndarray (3,)
        Mean specific force (m/s^2), body frame at the start of the cycle.
    J : dict of str to ndarray (3, 3)
        Derivatives with respect to ``att1``, ``att0`` (right perturbations of the attitudes at the end
        and at the start), ``v1``, ``w1``, ``v0``, ``w0``.
    """
    z, J = np.zeros(3), np.zeros((6, 3, 3))
    _engine.engine().mean_specific_force(_v3(phi), _v3(v0_B), _v3(w0_B), _v3(v1_B), _v3(w1_B), _v3(r_B), float(dt),
                                         z, J)
    return z, dict(zip(_JACOBIANS, J))


def tidal_mean_B0(q0_BN, r0_N, q1_BN, r1_N, r_B, mean_motion: float, t0: float, t1: float) -> np.ndarray:
    """The orbit's tidal acceleration at a point of B averaged over a cycle, in the body frame at its start (3,).

    ``g(x, t) = n^2 (3 (r . x) r - x)`` with ``r = (cos n t, sin n t, 0)`` the zenith in N (the orbit's
    frame at t = 0, see :class:`postcapture.config.schema.Orbit`), at the point ``r_N + C_NB r_B`` at both
    ends (trapezoid: the field changes over 0.1 s by a part in 10^4 of itself). An accelerometer reads the
    specific force, the acceleration less this: ``(mean specific force) = (kinematic mean) - tidal``.
    Its derivatives (about ``3 n^2``, 3e-6 (m/s^2)/m at 770 km) are left out of the measurement Jacobians.
    Computed by the engine (``pc_increments.c``), the filters' own model of it.
    """
    out = np.zeros(3)
    if mean_motion:
        _engine.engine().tidal_mean(_v3(q0_BN), _v3(r0_N), _v3(q1_BN), _v3(r1_N), _v3(r_B), float(mean_motion),
                                    float(t0), float(t1), out)
    return out


def calibration_matrix(c) -> np.ndarray:
    """``C`` (3, 3) of a triad's calibration vector ``c = (s (3), m (6))`` (:mod:`postcapture.core.triad`)."""
    C = np.zeros((3, 3))
    _engine.engine().triad_matrix(np.ascontiguousarray(c, dtype=float), C)
    return C


def calibration_sensitivity(w) -> np.ndarray:
    """``d (C w) / d c`` (3, 9): how errors of the calibration vector move the triad's reading of ``w``."""
    D = np.zeros((3, 9))
    _engine.engine().triad_sensitivity(_v3(w), D)
    return D
