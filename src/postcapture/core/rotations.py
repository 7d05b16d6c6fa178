"""Quaternions and rotations: the one place where attitude conventions live.

Conventions
-----------
* Quaternions are scalar-first ``(w, x, y, z)``, Hamilton product, unit norm, ``w >= 0`` on output.
* ``q_BN`` is the attitude of frame B relative to frame N. Its passive direction cosine matrix
  ``C_BN = dcm_from_quat(q_BN)`` maps N components to B components: ``v_B = C_BN @ v_N``.
  As a Hamilton quaternion, ``q_BN`` represents the active rotation ``R_NB = C_BN.T``; this is the
  quaternion Pinocchio stores (as ``x, y, z, w``) in a free-flyer configuration.
* Composition follows the frame chain: ``q_CN = compose(q_CB, q_BN)`` (same as ``C_CN = C_CB @ C_BN``).
* Perturbations are 3-vectors expressed in the body frame of the quaternion they perturb (right
  perturbation, as Pinocchio's tangent space): ``box_plus(q_BN, dtheta_B)``; ``box_minus`` inverts it.

Every function accepts one quaternion of shape ``(4,)`` or a history of shape ``(4, n)`` (component
axis first, time last), and 3-vectors likewise as ``(3,)`` or ``(3, n)``.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "IDENTITY",
    "exp_matrix",
    "cross3",
    "skew",
    "normalize",
    "conjugate",
    "compose",
    "dcm_from_quat",
    "quat_from_dcm",
    "quat_from_pinocchio",
    "quat_to_pinocchio",
    "exp_map",
    "log_map",
    "box_plus",
    "box_minus",
    "rotation_angle",
    "quat_rate",
    "right_jacobian_inv",
    "left_jacobian_inv",
]

IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


def cross3(a, b) -> np.ndarray:
    """Cross product of two 3-vectors; tens of times faster than ``np.cross`` for single vectors."""
    a0, a1, a2 = a.tolist() if isinstance(a, np.ndarray) else a
    b0, b1, b2 = b.tolist() if isinstance(b, np.ndarray) else b
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def skew(v):
    """Return the cross-product matrix ``[v x]`` of a 3-vector, so that ``skew(a) @ b == cross(a, b)``."""
    x, y, z = np.asarray(v, dtype=float)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _hamilton(p, q):
    """Raw Hamilton product ``p (x) q`` of quaternions with the component axis first."""
    p0, p1, p2, p3 = p
    q0, q1, q2, q3 = q
    return np.array(
        [
            p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
            p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
            p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
            p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0,
        ]
    )


def normalize(q):
    """Return the unit quaternion with ``w >= 0`` that represents the same rotation as ``q``."""
    q = np.asarray(q, dtype=float)
    q = q / np.sqrt(np.einsum("i...,i...->...", q, q))
    return q * np.where(q[0] < 0.0, -1.0, 1.0)


def conjugate(q):
    """Return the conjugate (the inverse of a unit quaternion): ``q_NB`` from ``q_BN``."""
    q = np.asarray(q, dtype=float)
    return q * np.array([1.0, -1.0, -1.0, -1.0]).reshape((4,) + (1,) * (q.ndim - 1))


def compose(q_CB, q_BN):
    """Compose attitudes along the frame chain: ``q_CN = compose(q_CB, q_BN)``.

    Equivalent to ``C_CN = C_CB @ C_BN``; as a Hamilton product it is ``q_BN (x) q_CB``.
    """
    return normalize(_hamilton(np.asarray(q_BN, dtype=float), np.asarray(q_CB, dtype=float)))


def dcm_from_quat(q_BN):
    """Passive DCM ``C_BN`` (maps N components to B components) of a single quaternion ``q_BN``."""
    w, x, y, z = np.asarray(q_BN, dtype=float) / np.linalg.norm(q_BN)
    # Active rotation matrix R(q) = R_NB, then transpose.
    R = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )
    return R.T


def quat_from_dcm(C_BN):
    """Quaternion ``q_BN`` (w >= 0) of a passive DCM ``C_BN`` (Shepperd's robust method)."""
    R = np.asarray(C_BN, dtype=float).T  # active R_NB
    tr = np.trace(R)
    cands = np.array([tr, R[0, 0], R[1, 1], R[2, 2]])
    i = int(np.argmax(cands))
    if i == 0:
        w = 0.5 * np.sqrt(1.0 + tr)
        q = [w, (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)]
    elif i == 1:
        x = 0.5 * np.sqrt(1.0 + 2 * R[0, 0] - tr)
        q = [(R[2, 1] - R[1, 2]) / (4 * x), x, (R[0, 1] + R[1, 0]) / (4 * x), (R[0, 2] + R[2, 0]) / (4 * x)]
    elif i == 2:
        y = 0.5 * np.sqrt(1.0 + 2 * R[1, 1] - tr)
        q = [(R[0, 2] - R[2, 0]) / (4 * y), (R[0, 1] + R[1, 0]) / (4 * y), y, (R[1, 2] + R[2, 1]) / (4 * y)]
    else:
        z = 0.5 * np.sqrt(1.0 + 2 * R[2, 2] - tr)
        q = [(R[1, 0] - R[0, 1]) / (4 * z), (R[0, 2] + R[2, 0]) / (4 * z), (R[1, 2] + R[2, 1]) / (4 * z), z]
    return normalize(np.array(q))


def quat_from_pinocchio(xyzw):
    """Convert Pinocchio's ``(x, y, z, w)`` storage to our scalar-first ``(w, x, y, z)``, w >= 0.

    This and :func:`quat_to_pinocchio` are the only places where the two orders meet.
    """
    xyzw = np.asarray(xyzw, dtype=float)
    return normalize(np.concatenate([xyzw[3:4], xyzw[0:3]], axis=0))


def quat_to_pinocchio(q):
    """Convert a scalar-first quaternion to Pinocchio's ``(x, y, z, w)`` storage."""
    q = normalize(q)
    return np.concatenate([q[1:4], q[0:1]], axis=0)


def exp_map(theta):
    """Quaternion of the rotation vector ``theta`` (rad): ``(cos(|t|/2), sin(|t|/2) t/|t|)``."""
    theta = np.asarray(theta, dtype=float)
    a = np.sqrt(np.einsum("i...,i...->...", theta, theta))
    half = 0.5 * a
    # sin(a/2)/a with its Taylor series near zero
    small = a < 1e-4
    safe = np.where(small, 1.0, a)
    k = np.where(small, 0.5 - a * a / 48.0, np.sin(half) / safe)
    return np.concatenate([np.cos(half)[None, ...], k * theta], axis=0)


def log_map(q):
    """Rotation vector (rad) of a quaternion, taking the shortest rotation (angle in [0, pi])."""
    q = normalize(q)
    v = q[1:4]
    s = np.sqrt(np.einsum("i...,i...->...", v, v))
    angle = 2.0 * np.arctan2(s, q[0])
    small = s < 1e-8
    safe = np.where(small, 1.0, s)
    k = np.where(small, 2.0 / np.maximum(q[0], 1e-300), angle / safe)
    return k * v


def box_plus(q_BN, dtheta_B):
    """Perturb an attitude by a small rotation expressed in its own body frame.

    ``box_plus(q_BN, d) = compose(exp_map(d), q_BN)``: the frame B' reached by rotating B by ``d``.
    """
    return compose(exp_map(dtheta_B), q_BN)


def box_minus(q1_BN, q2_BN):
    """Rotation vector ``d`` (in the body frame of ``q2``) with ``box_plus(q2, d) == q1``."""
    return log_map(_hamilton(conjugate(q2_BN), np.asarray(q1_BN, dtype=float)))


def rotation_angle(q1_BN, q2_BN):
    """Angle (rad, in [0, pi]) of the rotation between two attitudes."""
    return np.linalg.norm(box_minus(q1_BN, q2_BN), axis=0)


def quat_rate(q_BN, omega_BN_B):
    """Time derivative of ``q_BN`` for the body rate ``omega_BN_B``: ``0.5 q (x) (0, omega)``."""
    omega = np.asarray(omega_BN_B, dtype=float)
    zero = np.zeros((1,) + omega.shape[1:])
    return 0.5 * _hamilton(np.asarray(q_BN, dtype=float), np.concatenate([zero, omega], axis=0))


def exp_matrix(phi) -> np.ndarray:
    """Rotation matrix ``Exp(phi)`` of a rotation vector (Rodrigues): the active rotation by ``phi``.

    With ``phi = box_minus(q1_BN, q0_BN)`` it is ``C_{B0 B1}``: it maps B1 components to B0 components.
    """
    phi = np.asarray(phi, dtype=float)
    th = float(np.sqrt(phi @ phi))
    W = skew(phi)
    if th < 1e-6:
        return np.eye(3) + W + 0.5 * (W @ W)
    return np.eye(3) + (np.sin(th) / th) * W + ((1.0 - np.cos(th)) / (th * th)) * (W @ W)


def right_jacobian_inv(phi) -> np.ndarray:
    """Inverse right Jacobian of SO(3) at the rotation vector ``phi`` (3x3).

    ``log(exp(phi) exp(a)) = phi + right_jacobian_inv(phi) @ a`` to first order in ``a``; so the
    derivative of ``box_minus(q1 (+) a, q0 (+) b)`` is ``right_jacobian_inv(phi) a - left_jacobian_inv(phi) b``
    with ``phi = box_minus(q1, q0)``.
    """
    phi = np.asarray(phi, dtype=float)
    th = float(np.linalg.norm(phi))
    W = skew(phi)
    if th < 1e-4:
        c = 1.0 / 12.0 + th * th / 720.0
    else:
        c = 1.0 / (th * th) - (1.0 + np.cos(th)) / (2.0 * th * np.sin(th))
    return np.eye(3) + 0.5 * W + c * (W @ W)


def left_jacobian_inv(phi) -> np.ndarray:
    """Inverse left Jacobian of SO(3): ``log(exp(b) exp(phi)) = phi + left_jacobian_inv(phi) @ b`` to first order."""
    return right_jacobian_inv(-np.asarray(phi, dtype=float))
