"""The plant's equations written with Pinocchio: the tests' independent reference of the compiled core.

The package computes the plant's dynamics once, in the compiled core (``postcapture/dynamics/csrc``,
:class:`postcapture.dynamics.core.CompiledPlant`). This module, outside the package, writes the same
equations a second way, from a :class:`~postcapture.dynamics.system.System`'s public description (its
Pinocchio model, springs, input matrix ``B`` and parameter vector) and Pinocchio's algorithms
(``aba``, ``computeABADerivatives``, ``bodyRegressor``), so that the core can be checked against it.

The equations (see :mod:`postcapture.dynamics.system` for the coordinates):

    M(q) ddq + b(q, v) = tau,   tau = tau_springs(q, v) + B u,
    tau_springs = -A^T (k * (A e - r)) - A^T (d * (A w))   (on the elastic coordinates only),

with ``e = q[n_root_q:]``, ``w = v[n_root_v:]``, spring rows ``A``, stiffnesses ``k``, dampers ``d`` and
rest values ``r``, each ``k_j`` and ``d_j`` its nominal value times its scale in the parameter vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from postcapture.dynamics.system import System

__all__ = [
    "Springs", "springs", "spring_torque", "generalized_force", "acceleration", "acceleration_u", "derivatives",
    "derivatives_u", "ddq_dparams", "ddq_dmass", "elastic_energy", "kinetic_energy",
]


@dataclass(frozen=True)
class Springs:
    """The springs and dampers at the system's current scales.

    ``A`` (n_springs, n_e): spring rows; ``k``, ``d``, ``rest`` (n_springs,): stiffnesses and dampers
    (scaled), rest values; ``k_nom``, ``d_nom``: the nominal (unscaled) values; ``S_k``, ``S_d``
    (n_springs, n_p): which parameter scales each spring's stiffness and damper (a row of zeros: none).
    """

    A: np.ndarray
    k: np.ndarray
    d: np.ndarray
    rest: np.ndarray
    k_nom: np.ndarray
    d_nom: np.ndarray
    S_k: np.ndarray
    S_d: np.ndarray
    n_root_q: int
    n_root_v: int

    def torque(self, q, v) -> np.ndarray:
        """Generalised spring and damper forces, shape (nv,) (zero on the root)."""
        tau = np.zeros(len(v))
        if self.A.size:
            e, w = q[self.n_root_q :], v[self.n_root_v :]
            tau[self.n_root_v :] = -self.A.T @ (self.k * (self.A @ e - self.rest) + self.d * (self.A @ w))
        return tau

    def stiffness(self) -> np.ndarray:
        """``K_e = A^T diag(k) A`` (n_e, n_e): minus the derivative of the spring forces by ``e``."""
        return self.A.T @ (self.k[:, None] * self.A)

    def damping(self) -> np.ndarray:
        """``D_e = A^T diag(d) A`` (n_e, n_e)."""
        return self.A.T @ (self.d[:, None] * self.A)

    def torque_dparams(self, q, v) -> np.ndarray:
        """Derivative of the spring forces by the parameter vector, shape (n_e, n_p)."""
        stretch = self.k_nom * (self.A @ q[self.n_root_q :] - self.rest)
        rate = self.d_nom * (self.A @ v[self.n_root_v :])
        return -(self.A.T @ (stretch[:, None] * self.S_k + rate[:, None] * self.S_d))


def springs(system: System) -> Springs:
    """The springs of ``system`` at its current parameter vector."""
    sp = system.assembly.springs
    p = system.parameters()
    S_k, S_d = system._S_k, system._S_d  # the parameter that scales each spring (System's parameter data)
    k_nom, d_nom = np.asarray(sp.k, dtype=float), np.asarray(sp.d, dtype=float)
    k = k_nom * np.where(S_k.any(axis=1), S_k @ p, 1.0)
    d = d_nom * np.where(S_d.any(axis=1), S_d @ p, 1.0)
    return Springs(sp.matrix(system.n_e), k, d, np.asarray(sp.rest, dtype=float), k_nom, d_nom, S_k, S_d,
                   system.n_root_q, system.n_root_v)


# ---------------------------------------------------------------------- forces
def spring_torque(system: System, q, v) -> np.ndarray:
    """Generalised spring and damper forces, shape (nv,)."""
    return springs(system).torque(q, v)


def force_from_inputs(system: System, q, v, u, sp: Springs | None = None) -> np.ndarray:
    """``tau = tau_springs(q, v) + B u``."""
    sp = springs(system) if sp is None else sp
    return sp.torque(q, v) + system.B @ u


def generalized_force(system: System, q, v, t: float, u_extra=None) -> np.ndarray:
    """``tau`` with the inputs of the schedule at ``t`` plus ``u_extra``."""
    return force_from_inputs(system, q, v, system.input_vector(t, u_extra))


# ---------------------------------------------------------------------- dynamics
def acceleration_u(system: System, q, v, u, sp: Springs | None = None) -> np.ndarray:
    """``ddq`` (nv,) for an input vector ``u`` (n_u,), by Pinocchio's articulated-body algorithm."""
    return pin.aba(system.model, system.data, q, v, force_from_inputs(system, q, v, u, sp))


def acceleration(system: System, q, v, t: float, u_extra=None) -> np.ndarray:
    """``ddq`` (nv,) with the inputs of the schedule at ``t`` plus ``u_extra``."""
    return acceleration_u(system, q, v, system.input_vector(t, u_extra))


def derivatives_u(system: System, q, v, u, sp: Springs | None = None):
    """Acceleration and its exact partial derivatives by Pinocchio's ``computeABADerivatives``.

    Returns
    -------
    ddq : ndarray, shape (nv,)
    ddq_dq : ndarray, shape (nv, nv)
        With respect to a right tangent perturbation of ``q``, springs included.
    ddq_dv : ndarray, shape (nv, nv)
        Dampers included.
    Minv : ndarray, shape (nv, nv)
        Inverse mass matrix (= d ddq / d tau; the input partial is ``Minv @ system.B``).
    """
    sp = springs(system) if sp is None else sp
    model, data = system.model, system.data
    dq, dv, Minv = pin.computeABADerivatives(model, data, q, v, force_from_inputs(system, q, v, u, sp))
    ddq = data.ddq.copy()
    dq, dv, Minv = np.array(dq), np.array(dv), np.array(Minv)
    if system.n_e:
        r = system.n_root_v
        dq[:, r:] -= Minv[:, r:] @ sp.stiffness()
        dv[:, r:] -= Minv[:, r:] @ sp.damping()
    return ddq, dq, dv, Minv


def derivatives(system: System, q, v, t: float, u_extra=None):
    """:func:`derivatives_u` with the inputs of the schedule at ``t`` plus ``u_extra``."""
    return derivatives_u(system, q, v, system.input_vector(t, u_extra))


def ddq_dparams(system: System, q, v, ddq, Minv, sp: Springs | None = None) -> np.ndarray:
    """Derivative of ``ddq`` by the parameter vector at fixed ``(q, v, inputs)``, shape (nv, n_p).

    From ``M ddq + b = tau``: ``d ddq/dp = Minv (d tau/dp - d(M ddq + b)/dp)``. The inverse dynamics are
    linear in the target's inertial parameters: the body carrying the target exerts ``Y(v_j, a_j) pi_j``
    (Pinocchio's body regressor, local frame) through its joint Jacobian ``J``, with ``pi_j = L pi_T``
    (``L`` the T-frame-to-joint-frame transform of the parameters); the spring and damper forces are
    linear in their scales.
    """
    out = np.zeros((system.nv, len(system.parameter_names)))
    if system.layout.has_target:
        model, data, j = system.model, system.data, system._t_joint
        pin.forwardKinematics(model, data, q, v, ddq)
        J = pin.computeJointJacobian(model, data, q, j)
        Y = pin.bodyRegressor(data.v[j], data.a[j])
        out[:, :10] = -Minv @ (J.T @ (Y @ system._t_L))
    sp = springs(system) if sp is None else sp
    if sp.A.size:
        out += Minv[:, system.n_root_v :] @ sp.torque_dparams(q, v)
    return out


def ddq_dmass(system: System, q, v, ddq, Minv) -> np.ndarray:
    """Derivative of ``ddq`` by the total target mass (along :meth:`System.dparams_dmass`)."""
    return ddq_dparams(system, q, v, ddq, Minv) @ system.dparams_dmass()


# ---------------------------------------------------------------------- energy
def elastic_energy(system: System, q) -> float:
    """Potential energy stored in the springs (J)."""
    sp = springs(system)
    if not sp.A.size:
        return 0.0
    delta = sp.A @ q[system.n_root_q :] - sp.rest
    return 0.5 * float(sp.k @ (delta * delta))


def kinetic_energy(system: System, q, v) -> float:
    """Kinetic energy of the whole tree (J)."""
    return float(pin.computeKineticEnergy(system.model, system.data, q, v))

