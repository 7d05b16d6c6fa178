"""The free flyer's ``integrate`` (SE(3) exponential) and its tangent Jacobians on CasADi ``SX``.

The configuration block is Pinocchio's ``(x, y, z, qx, qy, qz, qw)``; the tangent ``xi = (v, w)`` is a
body twist (linear, angular). As :func:`pinocchio.integrate`,

    q1 = q0 exp(xi):  p1 = p0 + R0 V(w) v,   quat1 = quat0 * (cos(|w|/2), sin(|w|/2) w/|w|),

followed by the sign choice ``quat1 . quat0 >= 0`` and a first-order renormalisation
``quat1 (3 - |quat1|^2) / 2``. ``V(w) = I + B [w]x + C [w]x^2`` with ``B = (1 - cos t)/t^2`` and
``C = (t - sin t)/t^3`` (``t = |w|``). Below ``t^2 = 1e-2`` every coefficient is its Taylor series
(truncation error below 1e-20), so the map and its derivatives are exact at ``w = 0``.
"""

from __future__ import annotations

from postcapture.fmi._extras import import_casadi
from postcapture.fmi.symbolic.spatial import quat_to_matrix

__all__ = ["SMALL_ANGLE2", "integrate_free_flyer", "tangent_basis", "tangent_projector", "hamilton_xyzw"]

SMALL_ANGLE2 = 1e-2  # rad^2: switch to the Taylor series below this squared angle


def _series(t2, coefficients):
    out = coefficients[-1]
    for c in reversed(coefficients[:-1]):
        out = c + t2 * out
    return out


def hamilton_xyzw(a, b):
    """Hamilton product ``a * b`` of quaternions stored as (x, y, z, w)."""
    ca = import_casadi()
    ax, ay, az, aw = a[0], a[1], a[2], a[3]
    bx, by, bz, bw = b[0], b[1], b[2], b[3]
    return ca.vertcat(
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    )


def integrate_free_flyer(q0, xi):
    """``q0 (+) xi`` for one free-flyer block (see the module docstring).

    Parameters
    ----------
    q0 : SX, shape (7,)
        Position (m) then quaternion (x, y, z, w).
    xi : SX, shape (6,)
        Body twist times time: linear (m) then angular (rad).

    Returns
    -------
    SX, shape (7,)
    """
    ca = import_casadi()
    v, w = xi[:3], xi[3:]
    t2 = ca.dot(w, w)
    small = t2 < SMALL_ANGLE2
    t = ca.sqrt(t2)
    sinc_half = ca.if_else(
        small, _series(t2, [1 / 2, -1 / 48, 1 / 3840, -1 / 645120, 1 / 185794560]), ca.sin(t / 2) / t
    )
    cos_half = ca.if_else(small, _series(t2, [1.0, -1 / 8, 1 / 384, -1 / 46080, 1 / 10321920]), ca.cos(t / 2))
    c_coef = ca.if_else(
        small, _series(t2, [1 / 6, -1 / 120, 1 / 5040, -1 / 362880, 1 / 39916800]), (t - ca.sin(t)) / (t2 * t)
    )
    b_coef = 2 * sinc_half * sinc_half  # (1 - cos t) / t^2, free of cancellation
    wxv = ca.cross(w, v)
    Vv = v + b_coef * wxv + c_coef * ca.cross(w, wxv)
    quat0 = q0[3:7]
    R0 = quat_to_matrix(quat0[0], quat0[1], quat0[2], quat0[3])
    p1 = q0[:3] + R0 @ Vv
    e = ca.vertcat(sinc_half * w, cos_half)
    quat1 = hamilton_xyzw(quat0, e)
    quat1 = ca.if_else(ca.dot(quat1, quat0) < 0, -quat1, quat1)
    quat1 = quat1 * ((3 - ca.dot(quat1, quat1)) / 2)
    return ca.vertcat(p1, quat1)


def tangent_basis(q):
    """``L(q)`` (7x6): the ambient derivative of ``q (+) delta`` at ``delta = 0`` for a free-flyer block."""
    ca = import_casadi()
    x, y, z, w = q[3], q[4], q[5], q[6]
    L = ca.SX.zeros(7, 6)
    L[:3, :3] = quat_to_matrix(x, y, z, w)
    L[3:7, 3:6] = 0.5 * _quat_left(x, y, z, w)
    return L


def tangent_projector(q):
    """``L(q)^+`` (6x7): maps an ambient velocity of a free-flyer block at ``q`` to its body twist."""
    ca = import_casadi()
    x, y, z, w = q[3], q[4], q[5], q[6]
    P = ca.SX.zeros(6, 7)
    P[:3, :3] = quat_to_matrix(x, y, z, w).T
    P[3:6, 3:7] = 2.0 * _quat_left(x, y, z, w).T
    return P


def _quat_left(x, y, z, w):
    """4x3 matrix of ``d -> quat * (d, 0)`` in (x, y, z, w) storage."""
    ca = import_casadi()
    return ca.vertcat(
        ca.horzcat(w, -z, y),
        ca.horzcat(z, w, -x),
        ca.horzcat(-y, x, w),
        ca.horzcat(-x, -y, -z),
    )
