"""Spatial (6-D) algebra on CasADi ``SX`` expressions, in Pinocchio's conventions.

Twists and wrenches are 6-vectors ordered (linear, angular). A placement ``(R, p)`` of a child frame in
its parent maps child coordinates to parent ones, ``x_parent = R x_child + p`` (Pinocchio's ``SE3``).
Spatial inertias are 6x6 matrices ``[[m I, -[h]x], [[h]x, I_O]]`` with ``h = m c`` (kg m) and ``I_O``
the rotational inertia about the frame origin (kg m^2).

CasADi folds numeric zeros and ones as it builds expressions, so writing the algebra densely with
numeric joint placements still gives lean code.
"""

from __future__ import annotations

import numpy as np

from postcapture.fmi._extras import import_casadi

__all__ = [
    "skew",
    "rot_axis",
    "quat_to_matrix",
    "compose",
    "motion_act_inv",
    "force_act",
    "cross_motion",
    "cross_force",
    "inertia_matrix",
    "transform_inertia",
    "ldl_solve",
    "numeric",
]


def skew(a):
    """The 3x3 matrix ``[a]x`` with ``[a]x b = a x b``."""
    ca = import_casadi()
    return ca.vertcat(ca.horzcat(0, -a[2], a[1]), ca.horzcat(a[2], 0, -a[0]), ca.horzcat(-a[1], a[0], 0))


def rot_axis(axis: int, c, s):
    """Rotation by an angle with cosine ``c`` and sine ``s`` about coordinate axis ``axis`` (0, 1, 2)."""
    ca = import_casadi()
    R = ca.SX.eye(3)
    i, j = ((1, 2), (2, 0), (0, 1))[axis]
    R[i, i] = c
    R[i, j] = -s
    R[j, i] = s
    R[j, j] = c
    return R


def quat_to_matrix(x, y, z, w):
    """Rotation matrix of a unit quaternion given as (x, y, z, w), Eigen's ``toRotationMatrix`` formula."""
    ca = import_casadi()
    tx, ty, tz = 2 * x, 2 * y, 2 * z
    twx, twy, twz = tx * w, ty * w, tz * w
    txx, txy, txz = tx * x, ty * x, tz * x
    tyy, tyz, tzz = ty * y, tz * y, tz * z
    return ca.vertcat(
        ca.horzcat(1 - (tyy + tzz), txy - twz, txz + twy),
        ca.horzcat(txy + twz, 1 - (txx + tzz), tyz - twx),
        ca.horzcat(txz - twy, tyz + twx, 1 - (txx + tyy)),
    )


def compose(A, B):
    """Placement product ``A * B`` of two ``(R, p)`` pairs."""
    Ra, pa = A
    Rb, pb = B
    return Ra @ Rb, pa + Ra @ pb


def motion_act_inv(R, p, m):
    """A twist in parent coordinates seen in the child frame placed at ``(R, p)`` (Pinocchio ``actInv``)."""
    ca = import_casadi()
    lin, ang = m[:3], m[3:]
    Rt = R.T
    return ca.vertcat(Rt @ (lin - ca.cross(p, ang)), Rt @ ang)


def force_act(R, p, f):
    """A wrench in child coordinates seen in the parent frame (Pinocchio ``act`` on a force)."""
    ca = import_casadi()
    lin = R @ f[:3]
    return ca.vertcat(lin, R @ f[3:] + ca.cross(p, lin))


def cross_motion(v, m):
    """Spatial cross product of twists ``v x m``."""
    ca = import_casadi()
    return ca.vertcat(ca.cross(v[3:], m[:3]) + ca.cross(v[:3], m[3:]), ca.cross(v[3:], m[3:]))


def cross_force(v, f):
    """Spatial cross product of a twist and a wrench ``v x* f``."""
    ca = import_casadi()
    return ca.vertcat(ca.cross(v[3:], f[:3]), ca.cross(v[3:], f[3:]) + ca.cross(v[:3], f[:3]))


def inertia_matrix(params):
    """Spatial inertia from Pinocchio's dynamic parameters.

    Parameters
    ----------
    params : sequence of 10 scalars (numbers or SX)
        ``[m, m c_x, m c_y, m c_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]`` with the inertia about the frame
        origin (kg, kg m, kg m^2), as ``pinocchio.Inertia.toDynamicParameters``.

    Returns
    -------
    SX, shape (6, 6)
    """
    ca = import_casadi()
    m, hx, hy, hz, ixx, ixy, iyy, ixz, iyz, izz = (params[i] for i in range(10))
    out = ca.SX.zeros(6, 6)
    for i in range(3):
        out[i, i] = m
    H = skew(ca.vertcat(hx, hy, hz))
    out[:3, 3:] = -H
    out[3:, :3] = H
    out[3:, 3:] = ca.vertcat(ca.horzcat(ixx, ixy, ixz), ca.horzcat(ixy, iyy, iyz), ca.horzcat(ixz, iyz, izz))
    return out


def transform_inertia(R, p, inertia):
    """A child's articulated inertia seen in the parent frame, ``X^T I X``.

    ``X`` is the child's motion transform; only the upper triangle is computed and mirrored (the result
    is symmetric).
    """
    ca = import_casadi()
    Rt = R.T
    X = ca.SX.zeros(6, 6)
    X[:3, :3] = Rt
    X[:3, 3:] = -Rt @ skew(p)
    X[3:, 3:] = Rt
    T = inertia @ X
    out = ca.SX.zeros(6, 6)
    for a in range(6):
        for b in range(a, 6):
            e = ca.dot(X[:, a], T[:, b])
            out[a, b] = e
            out[b, a] = e
    return out


def ldl_solve(A, b):
    """Solve ``A x = b`` for a small symmetric positive-definite ``A`` by an unrolled LDL^T factorisation."""
    ca = import_casadi()
    n = A.shape[0]
    L = [[None] * n for _ in range(n)]
    D = [None] * n
    for j in range(n):
        s = A[j, j]
        for k in range(j):
            s = s - L[j][k] * L[j][k] * D[k]
        D[j] = s
        for i in range(j + 1, n):
            s = A[i, j]
            for k in range(j):
                s = s - L[i][k] * L[j][k] * D[k]
            L[i][j] = s / D[j]
    y = []
    for i in range(n):
        s = b[i]
        for k in range(i):
            s = s - L[i][k] * y[k]
        y.append(s)
    x = [None] * n
    for i in reversed(range(n)):
        s = y[i] / D[i]
        for k in range(i + 1, n):
            s = s - L[k][i] * x[k]
        x[i] = s
    return ca.vertcat(*x)


def numeric(matrix):
    """A numeric array as an SX constant (helper for placements and inertias)."""
    ca = import_casadi()
    return ca.SX(ca.DM(np.asarray(matrix, dtype=float)))
