"""The plant as a dynamical system: ``ddq = f(q, v, t, u, m)`` with its analytic derivatives.

Configuration ``q`` (length ``nq``) lives on the Lie group of the tree: the chaser root is a Pinocchio
free flyer (position of B in N, then the quaternion of R_NB stored as x, y, z, w), every other
coordinate is a revolute angle. Velocities ``v`` (length ``nv``) are the root's body twist (linear, then
angular, in B components) followed by the joint rates. Tangent perturbations of ``q`` are right
perturbations, as in Pinocchio (``pinocchio.integrate(model, q, dq)``).

Generalised forces: ``tau = tau_springs(q, v) + B u``, where ``u = [F_B (3), tau_B (3), tau_arm]``
(force at the chaser's origin and torque, both in B; the arm motor torques), and the springs and
dampers are linear in the elastic coordinates ``e = q[7:]`` (see :class:`SpringSet`).

Parameters ``p`` (:mod:`postcapture.dynamics.parameters`): the target hub's ten inertial parameters and
the spring and damper scales; ``target_mass`` is a shortcut that changes the hub's mass at a fixed
centre of mass and a fixed inertia about it (the panels keep their mass).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from postcapture.core.errors import DomainError
from postcapture.dynamics.assembly import Assembly
from postcapture.dynamics.bodies import MassProperties
from postcapture.dynamics.excitation import InputSchedule
from postcapture.dynamics.parameters import dmass_direction, dynamic_parameters, mass_properties, parameter_names, transform_matrix

__all__ = ["System"]


class System:
    """Dynamics of an assembled model under a known input schedule.

    Parameters
    ----------
    assembly : Assembly
        The model, layout and springs from :func:`postcapture.dynamics.assembly.assemble`.
    inputs : InputSchedule
        The known excitation ``u(t)``.
    input_matrix : ndarray, shape (nv, n_u), optional
        Replaces the default ``B`` (chaser wrench on the root, motor torques on their joints), e.g. to
        apply a tip force to a panel chain through its Jacobian at rest.
    """

    def __init__(self, assembly: Assembly, inputs: InputSchedule | None = None, input_matrix: np.ndarray | None = None):
        if inputs is None:
            inputs = InputSchedule((), assembly.layout.n_arm)
        self.assembly = assembly
        self.model = assembly.model
        self.data = self.model.createData()
        self.layout = assembly.layout
        self.inputs = inputs
        self.nq, self.nv = self.model.nq, self.model.nv
        ff = self.layout.free_flyer
        self.n_root_v, self.n_root_q = (6, 7) if ff else (0, 0)
        self.n_e = self.nv - self.n_root_v
        self.n_u = inputs.n_inputs
        self.scenario = None
        sp = assembly.springs
        self._A = sp.matrix(self.n_e)
        self._k_nom, self._d_nom, self._r = (np.asarray(x, dtype=float) for x in (sp.k, sp.d, sp.rest))
        self._init_parameters(sp.groups)
        self._q_off = self.nq - self.nv
        self.motor_v = np.asarray(self.layout.motor_v, dtype=int)
        self._ident = np.eye(self.nv)
        # Input matrix B (nv x n_u): chaser wrench on the root, motor torques on their joints.
        B = np.zeros((self.nv, self.n_u))
        if ff:
            B[:6, :6] = np.eye(6)
        for i, iv in enumerate(self.motor_v):
            B[iv, 6 + i] = 1.0
        self._custom_B = input_matrix is not None
        if self._custom_B:
            B = np.asarray(input_matrix, dtype=float)
            if B.shape != (self.nv, self.n_u):
                raise ValueError(f"input_matrix: expected shape {(self.nv, self.n_u)}, found {B.shape}")
        self.B = B
        # u -> tau scatter: every default input lands on its own velocity coordinate
        self._u_rows = np.nonzero(B.any(axis=1))[0]
        self._u_cols = np.array([int(np.nonzero(B[r])[0][0]) for r in self._u_rows], dtype=int)
        self._set_springs()

    # ------------------------------------------------------------------ parameters
    def _init_parameters(self, groups) -> None:
        """The named parameter vector (:mod:`postcapture.dynamics.parameters`) at its nominal value."""
        layout = self.layout
        panel_names = [p.name for p in layout.panels]
        self.parameter_names = parameter_names(panel_names, layout.has_target, layout.n_arm > 0)
        index = {name: i for i, name in enumerate(self.parameter_names)}
        n_p = len(self.parameter_names)
        # which scale multiplies each spring's stiffness (S_k) and damper (S_d); a row of zeros: none
        S_k = np.zeros((len(groups), n_p))
        S_d = np.zeros((len(groups), n_p))
        for j, group in enumerate(groups):
            if group == "arm":
                S_k[j, index["arm.stiffness_scale"]] = S_d[j, index["arm.damping_scale"]] = 1.0
            elif group is not None:
                name = panel_names[group[0]]
                S_k[j, index[f"{name}.{group[1]}_scale"]] = S_d[j, index[f"{name}.damping_scale"]] = 1.0
        self._S_k, self._S_d = S_k, S_d
        self._scaled_k, self._scaled_d = S_k.any(axis=1), S_d.any(axis=1)
        p = np.ones(n_p)
        if layout.has_target:
            fid = self.model.getFrameId("target")
            frame = self.model.frames[fid]
            hub = layout.target_hub
            self._t_joint = frame.parentJoint
            X = frame.placement
            self._t_L = transform_matrix(X.rotation, X.translation)  # T-frame parameters -> joint frame
            p[:10] = dynamic_parameters(hub)
            self._t_base = self.model.inertias[self._t_joint].toDynamicParameters() - self._t_L @ p[:10]
        self._p = p

    def parameters(self) -> np.ndarray:
        """The current parameter vector ``p`` (a copy), named by :attr:`parameter_names`."""
        return self._p.copy()

    def set_parameters(self, p) -> None:
        """Set the whole parameter vector (see :mod:`postcapture.dynamics.parameters`).

        Raises
        ------
        DomainError
            If ``p`` has the wrong length, is not finite, or gives a non-physical target (mass <= 0,
            inertia about its centre of mass not positive definite) or a negative scale.
        """
        p = np.array(p, dtype=float).reshape(-1)
        n_p = len(self.parameter_names)
        if p.shape != (n_p,) or not np.all(np.isfinite(p)):
            raise DomainError(f"parameters: expected {n_p} finite numbers ({', '.join(self.parameter_names)}), found {p}")
        n_i = 10 if self.layout.has_target else 0
        if np.any(p[n_i:] < 0.0):
            bad = [n for n, x in zip(self.parameter_names[n_i:], p[n_i:]) if x < 0]
            raise DomainError(f"parameters: expected scales >= 0, found negative {', '.join(bad)}")
        if n_i:
            props = mass_properties(p[:10]) if p[0] > 0 else None
            if props is None or np.linalg.eigvalsh(props.inertia)[0] <= 0.0:
                raise DomainError(f"parameters: expected a target hub with positive mass and positive definite "
                                  f"inertia about its centre of mass, found {p[:10]}")
            self.model.inertias[self._t_joint] = pin.Inertia.FromDynamicParameters(self._t_base + self._t_L @ p[:10])
        self._p = p
        self._set_springs()

    def update_parameters(self, values: dict) -> None:
        """Set some parameters by name (``{"arm.stiffness_scale": 0.9, ...}``), the others unchanged.

        Raises
        ------
        DomainError
            For an unknown name (the known ones are listed) or a non-physical result.
        """
        if not values:
            return
        p = self._p.copy()
        for name, value in values.items():
            if name not in self.parameter_names:
                raise DomainError(f"parameters: expected names among {', '.join(self.parameter_names)}, found {name!r}")
            p[self.parameter_names.index(name)] = value
        self.set_parameters(p)

    def _set_springs(self) -> None:
        """Spring and damper matrices at the current scales (new arrays: copies never share them)."""
        A, p = self._A, self._p
        k = self._k_nom * np.where(self._scaled_k, self._S_k @ p, 1.0)
        d = self._d_nom * np.where(self._scaled_d, self._S_d @ p, 1.0)
        self._k = k
        self.K_e = A.T @ (k[:, None] * A)
        self.D_e = A.T @ (d[:, None] * A)
        self._tau0 = A.T @ (k * self._r)
        # Fast path: without Spong rotors every spring acts on one coordinate and K, D are diagonal.
        self._diag = bool(np.count_nonzero(self.K_e - np.diag(np.diag(self.K_e))) == 0
                          and np.count_nonzero(self.D_e - np.diag(np.diag(self.D_e))) == 0)
        self._k_diag = np.diag(self.K_e).copy()
        self._d_diag = np.diag(self.D_e).copy()
        # Full-length copies aligned with v (zero on the root), used with q[nq - nv:] whose tail is e.
        self._k_full = np.concatenate([np.zeros(self.n_root_v), self._k_diag])
        self._d_full = np.concatenate([np.zeros(self.n_root_v), self._d_diag])
        self._tau0_full = np.concatenate([np.zeros(self.n_root_v), self._tau0])

    @property
    def target_mass(self) -> float:
        """Total target mass (kg), hub plus panels. Setting it changes the hub's mass at a fixed centre of
        mass and a fixed inertia about it."""
        if not self.layout.has_target:
            raise AttributeError("this scenario has no target")
        return float(self._p[0]) + self.layout.target_panel_mass

    @target_mass.setter
    def target_mass(self, value: float) -> None:
        if not self.layout.has_target:
            raise AttributeError("this scenario has no target")
        m_hub = float(value) - self.layout.target_panel_mass
        if not m_hub > 0.0:
            raise ValueError(f"target_mass: expected more than the panels' {self.layout.target_panel_mass} kg, found {value}")
        props = mass_properties(self._p[:10])
        p = self._p.copy()
        p[:10] = dynamic_parameters(MassProperties(m_hub, props.com, props.inertia))
        self.set_parameters(p)

    def dparams_dmass(self) -> np.ndarray:
        """``d p / d target_mass`` (n_p,): the hub's mass at a fixed centre of mass and inertia about it."""
        out = np.zeros(len(self.parameter_names))
        out[:10] = dmass_direction(self._p[:10])
        return out

    def copy(self) -> "System":
        """An independent system (own model and data), e.g. for a filter with its own mass estimate."""
        other = System.__new__(System)
        other.__dict__.update(self.__dict__)
        other.model = pin.Model(self.model)
        other.data = other.model.createData()
        return other

    # ------------------------------------------------------------------ forces
    def spring_torque(self, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Generalised spring and damper forces, shape (nv,)."""
        tau = np.zeros(self.nv)
        if self.n_e:
            r, rq = self.n_root_v, self.n_root_q
            if self._diag:
                tau[r:] = self._tau0 - self._k_diag * q[rq:] - self._d_diag * v[r:]
            else:
                tau[r:] = self._tau0 - self.K_e @ q[rq:] - self.D_e @ v[r:]
        return tau

    def input_vector(self, t: float, u_extra=None, left: bool = False) -> np.ndarray:
        """``u(t) + u_extra``, shape (n_u,); ``left`` takes the schedule's left limit at ``t``."""
        u = self.inputs(t, left)
        return u if u_extra is None else u + u_extra

    def force_from_inputs(self, q, v, u) -> np.ndarray:
        """``tau = tau_springs(q, v) + B u``."""
        tau = self.spring_torque(q, v)
        if self._custom_B:
            return tau + self.B @ u
        if self.n_root_v:
            tau[:6] += u[:6]
        if self.motor_v.size:
            tau[self.motor_v] += u[6:]
        return tau

    def generalized_force(self, q, v, t: float, u_extra=None) -> np.ndarray:
        """``tau = tau_springs + B (u(t) + u_extra)``."""
        return self.force_from_inputs(q, v, self.input_vector(t, u_extra))

    # ------------------------------------------------------------------ dynamics
    def acceleration(self, q, v, t: float, u_extra=None) -> np.ndarray:
        """Generalised acceleration ``ddq`` (nv,) by Featherstone's articulated-body algorithm."""
        return pin.aba(self.model, self.data, q, v, self.generalized_force(q, v, t, u_extra))

    def acceleration_u(self, q, v, u) -> np.ndarray:
        """``ddq`` for a given input vector ``u`` (n_u,) instead of the schedule."""
        return pin.aba(self.model, self.data, q, v, self.force_from_inputs(q, v, u))

    def input_torque(self, u) -> np.ndarray:
        """``B u + tau_0``: the input forces plus the springs' constant (rest-angle) term, shape (nv,).

        This is what :meth:`acceleration_tau` takes; computed once per integrator stage.
        """
        if self._custom_B:
            return self._tau0_full + self.B @ u
        tau = self._tau0_full.copy()
        tau[self._u_rows] += u[self._u_cols]
        return tau

    def acceleration_tau(self, q, v, tau_u) -> np.ndarray:
        """``ddq`` given ``tau_u = input_torque(u)`` (the integrator's inner loop)."""
        if self._diag:
            tau = tau_u - self._k_full * q[self._q_off :] - self._d_full * v
            return pin.aba(self.model, self.data, q, v, tau)
        return pin.aba(self.model, self.data, q, v, tau_u - self._tau0_full + self.spring_torque(q, v))

    def derivatives(self, q, v, t: float, u_extra=None):
        """See :meth:`derivatives_u`; the inputs come from the schedule at ``t`` plus ``u_extra``."""
        return self.derivatives_u(q, v, self.input_vector(t, u_extra))

    def derivatives_u(self, q, v, u):
        """Acceleration and its exact partial derivatives.

        Returns
        -------
        ddq : ndarray, shape (nv,)
        ddq_dq : ndarray, shape (nv, nv)
            With respect to a right tangent perturbation of ``q``, springs included.
        ddq_dv : ndarray, shape (nv, nv)
            Dampers included.
        Minv : ndarray, shape (nv, nv)
            Inverse mass matrix (= d ddq / d tau).
        """
        tau = self.force_from_inputs(q, v, u)
        dq, dv, Minv = pin.computeABADerivatives(self.model, self.data, q, v, tau)
        ddq = self.data.ddq.copy()
        dq, dv, Minv = np.array(dq), np.array(dv), np.array(Minv)
        if self.n_e:
            r = self.n_root_v
            dq[:, r:] -= Minv[:, r:] @ self.K_e
            dv[:, r:] -= Minv[:, r:] @ self.D_e
        return ddq, dq, dv, Minv

    def ddq_dparams(self, q, v, ddq, Minv) -> np.ndarray:
        """Exact derivative of ``ddq`` with respect to the parameter vector at fixed ``(q, v, inputs)``, (nv, n_p).

        From ``M ddq + b = tau``: ``d ddq/dp = Minv (d tau/dp - d(M ddq + b)/dp)``. The inverse dynamics
        are linear in the target's inertial parameters: the body carrying the target exerts
        ``Y(v_j, a_j) pi_j`` (Pinocchio's body regressor, local frame) through its joint Jacobian ``J``,
        with ``pi_j = L pi_T``; the spring and damper torques are linear in their scales.
        """
        out = np.zeros((self.nv, len(self.parameter_names)))
        if self.layout.has_target:
            model, data, j = self.model, self.data, self._t_joint
            pin.forwardKinematics(model, data, q, v, ddq)
            J = pin.computeJointJacobian(model, data, q, j)
            Y = pin.bodyRegressor(data.v[j], data.a[j])
            out[:, :10] = -Minv @ (J.T @ (Y @ self._t_L))
        if self._k_nom.size:
            r = self.n_root_v
            A = self._A
            stretch = self._k_nom * (A @ q[self.n_root_q :] - self._r)
            rate = self._d_nom * (A @ v[r:])
            dtau = -(A.T @ (stretch[:, None] * self._S_k + rate[:, None] * self._S_d))
            out += Minv[:, r:] @ dtau
        return out

    def ddq_dmass(self, q, v, ddq, Minv) -> np.ndarray:
        """Exact derivative of ``ddq`` with respect to the total target mass (see :meth:`dparams_dmass`)."""
        return self.ddq_dparams(q, v, ddq, Minv) @ self.dparams_dmass()

    # ------------------------------------------------------------------ energy
    def elastic_energy(self, q) -> float:
        """Potential energy stored in the springs (J)."""
        if not self.n_e:
            return 0.0
        delta = self._A @ q[self.n_root_q :] - self._r
        return 0.5 * float(self._k @ (delta * delta))

    def kinetic_energy(self, q, v) -> float:
        """Kinetic energy of the whole tree (J)."""
        return float(pin.computeKineticEnergy(self.model, self.data, q, v))

    def damping_power(self, v) -> float:
        """Power dissipated by the dampers (W, >= 0)."""
        if not self.n_e:
            return 0.0
        w = v[self.n_root_v :]
        return float(w @ (self.D_e @ w))

    # ------------------------------------------------------------------ Lie group
    def integrate(self, q, dq) -> np.ndarray:
        """``q (+) dq`` on the configuration group."""
        return pin.integrate(self.model, q, dq)

    def difference(self, q0, q1) -> np.ndarray:
        """Tangent vector ``dq`` with ``q0 (+) dq = q1``."""
        return pin.difference(self.model, q0, q1)
