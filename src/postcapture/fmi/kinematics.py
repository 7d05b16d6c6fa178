"""Tangent spaces of FMU states: box-plus / box-minus and the maps between ambient and tangent rates.

A filter works on tangent (error) coordinates; an FMU exchanges ambient ones (a quaternion has four
entries). Two layouts are supported (the mapping's ``kinematics``):

``free_flyer``
    ``x = [q (nq), v (nq - 1)]`` with ``q[:7]`` a free flyer (position, quaternion x y z w, Pinocchio's
    layout) and Euclidean joints: tangents are right perturbations of the body twist, as in
    :class:`postcapture.dynamics.process_model.NativeProcessModel` (the same Lie group code: the
    compiled core's box-plus and box-minus, :mod:`postcapture.dynamics.liegroup`).
``quaternion``
    Any state with a unit quaternion ``q_BN`` (scalar first) among its entries: the tangent is
    ``[dtheta_B (3), the other entries in order]`` with ``q (+) dtheta = q exp(dtheta)``.

For the directional-derivative path each layout also gives ``L(x)`` (tangent to ambient, the
derivative of ``x (+) d`` at ``d = 0``), its left inverse ``L(x)^+`` and ``d/dt L(x(t))^+``, so that
the tangent linearisation is ``A_t = L^+ A L + (d/dt L^+) L``.
"""

from __future__ import annotations

import numpy as np

from postcapture.core.rotations import box_minus, box_plus
from postcapture.dynamics.liegroup import difference, integrate

__all__ = ["FreeFlyerKinematics", "QuaternionKinematics", "layout_problems", "make_kinematics"]


def _quat_matrix_xyzw(x, y, z, w) -> np.ndarray:
    """Rotation matrix of a quaternion (x, y, z, w) (Eigen's formula, quadratic in the entries)."""
    tx, ty, tz = 2 * x, 2 * y, 2 * z
    twx, twy, twz = tx * w, ty * w, tz * w
    txx, txy, txz = tx * x, ty * x, tz * x
    tyy, tyz, tzz = ty * y, tz * y, tz * z
    return np.array(
        [
            [1 - (tyy + tzz), txy - twz, txz + twy],
            [txy + twz, 1 - (txx + tzz), tyz - twx],
            [txz - twy, tyz + twx, 1 - (txx + tyy)],
        ]
    )


def _left_xyzw(x, y, z, w) -> np.ndarray:
    """4x3 matrix of ``d -> quat * (d, 0)`` for a quaternion stored (x, y, z, w)."""
    return np.array([[w, -z, y], [z, w, -x], [-y, x, w], [-x, -y, -z]])


def _left_wxyz(w, x, y, z) -> np.ndarray:
    """4x3 matrix of ``d -> q * (0, d)`` for a quaternion stored (w, x, y, z)."""
    return np.array([[-x, -y, -z], [w, -z, y], [z, w, -x], [-y, x, w]])


class FreeFlyerKinematics:
    """Free flyer plus Euclidean joints (see the module docstring).

    Parameters
    ----------
    nx : int
        State size ``nq + nv`` with ``nv = nq - 1``.
    """

    name = "free_flyer"

    def __init__(self, nx: int):
        if nx < 13 or nx % 2 == 0:
            raise ValueError(f"free_flyer kinematics: expected nx = 2 nq - 1 >= 13, found {nx}")
        self.nq = (nx + 1) // 2
        self.nv = self.nq - 1
        self.nx, self.n = nx, 2 * self.nv
        self.tangent_attitude = slice(3, 6)
        self.tangent_rate = slice(self.nv + 3, self.nv + 6)

    def tangent_index(self, i: int) -> int | None:
        """Where the state entry ``i`` (a joint angle or a velocity) sits in the tangent; None for the root's
        position and quaternion, which have no tangent entry of their own."""
        if i < 7:
            return None
        return i - 1 if i < self.nq else self.nv + (i - self.nq)

    def retract(self, x: np.ndarray, dx: np.ndarray) -> np.ndarray:
        """``x (+) dx``, shape (nx,)."""
        nq, nv = self.nq, self.nv
        return np.concatenate([integrate(x[:nq], dx[:nv], nq, nv, True), x[nq:] + dx[nv:]])

    def local(self, x1: np.ndarray, x0: np.ndarray) -> np.ndarray:
        """``x1 (-) x0``, shape (n,)."""
        nq = self.nq
        return np.concatenate([difference(x0[:nq], x1[:nq], nq, self.nv, True), x1[nq:] - x0[nq:]])

    def basis(self, x: np.ndarray) -> np.ndarray:
        """``L(x)`` (nx, n)."""
        L = np.zeros((self.nx, self.n))
        L[:3, :3] = _quat_matrix_xyzw(*x[3:7])
        L[3:7, 3:6] = 0.5 * _left_xyzw(*x[3:7])
        L[7:, 6:] = np.eye(self.nx - 7)
        return L

    def projector(self, x: np.ndarray) -> np.ndarray:
        """``L(x)^+`` (n, nx)."""
        P = np.zeros((self.n, self.nx))
        P[:3, :3] = _quat_matrix_xyzw(*x[3:7]).T
        P[3:6, 3:7] = 2.0 * _left_xyzw(*x[3:7]).T
        P[6:, 7:] = np.eye(self.nx - 7)
        return P

    def projector_rate(self, x: np.ndarray, xdot: np.ndarray) -> np.ndarray:
        """``d/dt L(x)^+`` along ``xdot`` (n, nx).

        The rotation matrix is quadratic in the quaternion, so its central difference with a unit step is
        its exact derivative.
        """
        D = np.zeros((self.n, self.nx))
        qa, qd = x[3:7], xdot[3:7]
        D[:3, :3] = 0.5 * (_quat_matrix_xyzw(*(qa + qd)) - _quat_matrix_xyzw(*(qa - qd))).T
        D[3:6, 3:7] = 2.0 * _left_xyzw(*qd).T
        return D


class QuaternionKinematics:
    """A unit quaternion ``q_BN`` (w, x, y, z at ``attitude``) in an otherwise Euclidean state.

    Parameters
    ----------
    nx : int
        State size.
    attitude : sequence of 4 int
        Indices of q_BN (w, x, y, z) in the state.
    rate : sequence of 3 int
        Indices of omega_BN_B in the state (contiguous and in order in the tangent).
    """

    name = "quaternion"

    def __init__(self, nx: int, attitude, rate):
        self.nx, self.n = nx, nx - 1
        self.att = np.asarray(attitude, dtype=int)
        self.rest = np.array([i for i in range(nx) if i not in set(self.att.tolist())], dtype=int)
        pos = {int(i): 3 + k for k, i in enumerate(self.rest)}
        r = [pos[int(i)] for i in rate]
        if r != list(range(r[0], r[0] + 3)):
            raise ValueError(
                "quaternion kinematics: the rate entries must be consecutive and in x, y, z order"
            )
        self.tangent_attitude = slice(0, 3)
        self.tangent_rate = slice(r[0], r[0] + 3)
        self._pos = pos

    def tangent_index(self, i: int) -> int | None:
        """Where the state entry ``i`` sits in the tangent; None for an attitude entry."""
        return self._pos.get(int(i))

    def retract(self, x, dx):
        """``x (+) dx``, shape (nx,)."""
        out = np.array(x, dtype=float)
        out[self.att] = box_plus(x[self.att], dx[:3])
        out[self.rest] = x[self.rest] + dx[3:]
        return out

    def local(self, x1, x0):
        """``x1 (-) x0``, shape (n,)."""
        return np.concatenate([box_minus(x1[self.att], x0[self.att]), x1[self.rest] - x0[self.rest]])

    def basis(self, x):
        """``L(x)`` (nx, n)."""
        L = np.zeros((self.nx, self.n))
        L[np.ix_(self.att, range(3))] = 0.5 * _left_wxyz(*x[self.att])
        L[self.rest, 3 + np.arange(self.rest.size)] = 1.0
        return L

    def projector(self, x):
        """``L(x)^+`` (n, nx)."""
        P = np.zeros((self.n, self.nx))
        P[np.ix_(range(3), self.att)] = 2.0 * _left_wxyz(*x[self.att]).T
        P[3 + np.arange(self.rest.size), self.rest] = 1.0
        return P

    def projector_rate(self, x, xdot):
        """``d/dt L(x)^+`` along ``xdot`` (n, nx)."""
        D = np.zeros((self.n, self.nx))
        D[np.ix_(range(3), self.att)] = 2.0 * _left_wxyz(*xdot[self.att]).T
        return D


def _index_problems(nx: int, att: list[int], rt: list[int]) -> list[str]:
    """Problems of the attitude and rate indices themselves (range, distinct, not shared)."""
    problems = []
    if any(not 0 <= i < nx for i in att + rt):
        problems.append(f"attitude and rate entries must be among the {nx} state entries")
    if len(set(att)) != 4:
        problems.append("the four attitude entries must be distinct")
    if len(set(rt)) != 3:
        problems.append("the three rate entries must be distinct")
    shared = sorted(set(att) & set(rt))
    if shared:
        problems.append(f"attitude and rate share state entr{'ies' if len(shared) > 1 else 'y'} "
                        f"{', '.join(str(i + 1) for i in shared)} (1-based): they must not overlap")
    return problems


def _free_flyer_problems(nx: int, att: list[int], rt: list[int]) -> list[str]:
    if nx < 13 or nx % 2 == 0:
        return [f"free_flyer kinematics: expected nx = 2 nq - 1 >= 13 state entries, found {nx}"]
    nq = (nx + 1) // 2
    if att != [6, 3, 4, 5] or rt != [nq + 3, nq + 4, nq + 5]:
        return ["free_flyer kinematics: attitude must be q[7], q[4], q[5], q[6] and rate v[4], v[5], v[6] "
                "of a Pinocchio free-flyer state"]
    return []


def _quaternion_problems(nx: int, att: list[int], rt: list[int]) -> list[str]:
    rest = [i for i in range(nx) if i not in set(att)]
    pos = [rest.index(i) for i in rt]
    if pos != list(range(pos[0], pos[0] + 3)):
        return ["quaternion kinematics: the rate entries must be consecutive in the state (apart from the "
                "attitude entries) and in x, y, z order"]
    return []


def layout_problems(kind: str, nx: int, attitude, rate) -> list[str]:
    """Every reason why indices of q_BN (w, x, y, z) and of the rates do not fit layout ``kind``.

    Parameters
    ----------
    kind : str
        ``"free_flyer"`` or ``"quaternion"``.
    nx : int
        State size.
    attitude, rate : sequence of int
        Indices (0-based) of q_BN (w, x, y, z) and of omega_BN_B (x, y, z) in the state.

    Returns
    -------
    list of str
        Empty when the layout is usable.
    """
    att, rt = [int(i) for i in attitude], [int(i) for i in rate]
    if len(att) != 4 or len(rt) != 3:
        return [f"expected 4 attitude and 3 rate entries, found {len(att)} and {len(rt)}"]
    problems = _index_problems(nx, att, rt)
    if problems:
        return problems
    checks = {"free_flyer": _free_flyer_problems, "quaternion": _quaternion_problems}
    if kind not in checks:
        return [f"kinematics: expected free_flyer or quaternion, found {kind!r}"]
    return checks[kind](nx, att, rt)


def make_kinematics(kind: str, nx: int, attitude, rate):
    """The tangent layout ``kind`` of a state of size ``nx`` (indices of q_BN (w, x, y, z) and rates).

    Raises
    ------
    ValueError
        With every problem of :func:`layout_problems`.
    """
    problems = layout_problems(kind, nx, attitude, rate)
    if problems:
        raise ValueError("; ".join(problems))
    if kind == "free_flyer":
        return FreeFlyerKinematics(nx)
    return QuaternionKinematics(nx, attitude, rate)
