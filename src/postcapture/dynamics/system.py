"""The plant's description: its model, springs, inputs and parameters, from which the compiled core is built.

The plant's equations, ``M(q) ddq + b(q, v) = tau_springs(q, v) + B u``, their partial derivatives, the
integrators and the measurements are computed once, in the compiled core
(:class:`postcapture.dynamics.core.CompiledPlant`, built from a :class:`System` by
:func:`postcapture.dynamics.packing.pack`). A :class:`System` holds what that core is built from: the
Pinocchio model, the springs, the input matrix ``B`` and schedule ``u(t)``, the parameter vector. (The tests
write the same equations a second way, with Pinocchio, in ``tests/pinocchio_reference.py``: the core's
independent reference.)

Configuration ``q`` (length ``nq``) lives on the Lie group of the tree: the chaser root is a Pinocchio
free flyer (position of B in N, then the quaternion of R_NB stored as x, y, z, w), every other
coordinate is a revolute angle. Velocities ``v`` (length ``nv``) are the root's body twist (linear, then
angular, in B components) followed by the joint rates. Tangent perturbations of ``q`` are right
perturbations, as in Pinocchio (``pinocchio.integrate(model, q, dq)``).

Generalised forces: ``tau = tau_springs(q, v) + B u``, where ``u = [F_B (3), tau_B (3), tau_arm]``
(force at the chaser's origin and torque, both in B; the arm motor torques), and the springs and
dampers are linear in the elastic coordinates ``e = q[7:]`` (see
:class:`~postcapture.dynamics.assembly.SpringSet`): ``K_e``, ``D_e`` are their stiffness and damping
matrices at the current scales.

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
    """An assembled model under a known input schedule: what the compiled core is built from.

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
        self._init_parameters(assembly.springs.groups)
        # Input matrix B (nv x n_u): chaser wrench on the root, motor torques on their joints.
        B = np.zeros((self.nv, self.n_u))
        if ff:
            B[:6, :6] = np.eye(6)
        for i, iv in enumerate(self.layout.motor_v):
            B[iv, 6 + i] = 1.0
        self._custom_B = input_matrix is not None
        if self._custom_B:
            B = np.asarray(input_matrix, dtype=float)
            if B.shape != (self.nv, self.n_u):
                raise ValueError(f"input_matrix: expected shape {(self.nv, self.n_u)}, found {B.shape}")
        self.B = B
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
        """Forget the spring matrices of the former scales; :attr:`K_e` and :attr:`D_e` are formed when read
        (a filter's plant copy changes its parameters at every step and never reads them)."""
        self._springs = None

    def _spring_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        if self._springs is None:
            sp, p = self.assembly.springs, self._p
            A = sp.matrix(self.n_e)
            k = np.asarray(sp.k, dtype=float) * np.where(self._S_k.any(axis=1), self._S_k @ p, 1.0)
            d = np.asarray(sp.d, dtype=float) * np.where(self._S_d.any(axis=1), self._S_d @ p, 1.0)
            self._springs = (A.T @ (k[:, None] * A), A.T @ (d[:, None] * A))
        return self._springs

    @property
    def K_e(self) -> np.ndarray:
        """``K_e = A^T diag(k) A`` (n_e x n_e) at the current scales; used by the modal analysis at rest."""
        return self._spring_matrices()[0].copy()

    @property
    def D_e(self) -> np.ndarray:
        """``D_e = A^T diag(d) A`` (n_e x n_e) at the current scales."""
        return self._spring_matrices()[1].copy()

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

    # ------------------------------------------------------------------ inputs
    def input_vector(self, t: float, u_extra=None, left: bool = False) -> np.ndarray:
        """``u(t) + u_extra``, shape (n_u,); ``left`` takes the schedule's left limit at ``t``."""
        u = self.inputs(t, left)
        return u if u_extra is None else u + u_extra

    # ------------------------------------------------------------------ Lie group
    def integrate(self, q, dq) -> np.ndarray:
        """``q (+) dq`` on the configuration group."""
        return pin.integrate(self.model, q, dq)

    def difference(self, q0, q1) -> np.ndarray:
        """Tangent vector ``dq`` with ``q0 (+) dq = q1``."""
        return pin.difference(self.model, q0, q1)
