"""The plant's description: its tree, springs, inputs and parameter vector, from which the compiled core is built.

The plant's equations, ``M(q) ddq + b(q, v) = tau_springs(q, v) + B u``, their partial derivatives, the
integrators and the measurements are computed once, in the compiled core
(:class:`postcapture.dynamics.core.CompiledPlant`, built from a :class:`System` by
:func:`postcapture.dynamics.packing.pack`). A :class:`System` is an immutable description of what that
core is built from: the joint tree (:class:`~postcapture.dynamics.tree.Tree`, plain data), the springs,
the input matrix ``B`` and schedule ``u(t)``, and a parameter vector. It never changes: methods such as
:meth:`System.with_parameters` return another description, and copies share nothing mutable. The
*current* parameters of a running plant belong to its instance in the core (one owner). The tests
write the same equations a second way, with Pinocchio, in ``tests/pinocchio_reference.py``.

Configuration ``q`` (length ``nq``) lives on the Lie group of the tree: the chaser root is a free flyer
(position of B in N, then the quaternion of R_NB stored as x, y, z, w), every other coordinate is a
revolute angle. Velocities ``v`` (length ``nv``) are the root's body twist (linear, then angular, in B
components) followed by the joint rates. Tangent perturbations of ``q`` are right perturbations.

Generalised forces: ``tau = tau_springs(q, v) + B u``, where ``u = [F_B (3), tau_B (3), tau_arm]``
(force at the chaser's origin and torque, both in B; the arm motor torques), and the springs and
dampers are linear in the elastic coordinates ``e = q[7:]`` (see
:class:`~postcapture.dynamics.assembly.SpringSet`).

Parameters ``p`` (:mod:`postcapture.dynamics.parameters`): the target hub's ten inertial parameters and
the spring and damper scales; ``target_mass`` is the hub's mass plus the target panels', and changing
it moves the hub's mass at a fixed centre of mass and a fixed inertia about it.
"""

from __future__ import annotations

import numpy as np

from postcapture.dynamics.assembly import Assembly
from postcapture.dynamics.excitation import InputSchedule
from postcapture.dynamics.parameters import (check_parameters, dmass_direction, dynamic_parameters, parameter_names,
                                             transform_matrix, with_target_mass)

__all__ = ["System"]


def _frozen(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


class System:
    """An assembled model under a known input schedule, with a parameter vector: immutable.

    Parameters
    ----------
    assembly : Assembly
        The tree, layout and springs from :func:`postcapture.dynamics.assembly.assemble`.
    inputs : InputSchedule
        The known excitation ``u(t)``.
    input_matrix : ndarray, shape (nv, n_u), optional
        Replaces the default ``B`` (chaser wrench on the root, motor torques on their joints), e.g. to
        apply a tip force to a panel chain through its Jacobian at rest.
    parameters : ndarray, optional
        The parameter vector (default: the assembly's nominal one).
    """

    __slots__ = ("assembly", "tree", "layout", "inputs", "nq", "nv", "n_root_v", "n_root_q", "n_e", "n_u", "scenario",
                 "B", "custom_input_matrix", "parameter_names", "spring_k", "spring_d", "target_joint", "target_map",
                 "target_base", "_p")

    def __init__(self, assembly: Assembly, inputs: InputSchedule | None = None, input_matrix=None, *,
                 parameters=None, scenario=None):
        set_ = object.__setattr__
        layout = assembly.layout
        tree = assembly.tree
        set_(self, "assembly", assembly)
        set_(self, "tree", tree)
        set_(self, "layout", layout)
        set_(self, "inputs", inputs if inputs is not None else InputSchedule((), layout.n_arm))
        set_(self, "nq", tree.nq)
        set_(self, "nv", tree.nv)
        ff = layout.free_flyer
        set_(self, "n_root_v", 6 if ff else 0)
        set_(self, "n_root_q", 7 if ff else 0)
        set_(self, "n_e", self.nv - self.n_root_v)
        set_(self, "n_u", self.inputs.n_inputs)
        set_(self, "scenario", scenario)
        set_(self, "custom_input_matrix", input_matrix is not None)
        set_(self, "B", _frozen(self._input_matrix(input_matrix)))
        self._init_parameters(parameters)

    def __reduce__(self):
        return (_rebuild, (self.assembly, self.inputs, self.B if self.custom_input_matrix else None, self._p,
                           self.scenario))

    def __setattr__(self, name, value):
        raise AttributeError(f"System is immutable: use with_parameters(), with_updates() or with_target_mass() "
                             f"instead of setting {name!r}")

    def _input_matrix(self, input_matrix) -> np.ndarray:
        if input_matrix is not None:
            B = np.asarray(input_matrix, dtype=float)
            if B.shape != (self.nv, self.n_u):
                raise ValueError(f"input_matrix: expected shape {(self.nv, self.n_u)}, found {B.shape}")
            return B
        B = np.zeros((self.nv, self.n_u))
        if self.layout.free_flyer:
            B[:6, :6] = np.eye(6)
        for i, iv in enumerate(self.layout.motor_v):
            B[iv, 6 + i] = 1.0
        return B

    # ------------------------------------------------------------------ parameters
    def _init_parameters(self, parameters) -> None:
        """The named parameter vector (:mod:`postcapture.dynamics.parameters`) and which entry scales each spring."""
        set_ = object.__setattr__
        layout = self.layout
        panel_names = [p.name for p in layout.panels]
        names = parameter_names(panel_names, layout.has_target, layout.n_arm > 0)
        index = {name: i for i, name in enumerate(names)}
        k_idx, d_idx = [], []
        for group in self.assembly.springs.groups:
            if group == "arm":
                k_idx.append(index["arm.stiffness_scale"])
                d_idx.append(index["arm.damping_scale"])
            elif group is not None:
                name = panel_names[group[0]]
                k_idx.append(index[f"{name}.{group[1]}_scale"])
                d_idx.append(index[f"{name}.damping_scale"])
            else:
                k_idx.append(-1)
                d_idx.append(-1)
        set_(self, "parameter_names", names)
        set_(self, "spring_k", tuple(k_idx))
        set_(self, "spring_d", tuple(d_idx))
        p = np.ones(len(names))
        target_joint, L, base = -1, np.zeros((10, 10)), np.zeros(10)
        if layout.has_target:
            frame = self.tree.frame("target")
            target_joint = frame.joint
            L = transform_matrix(frame.rotation, frame.translation)  # T-frame parameters -> joint frame
            p[:10] = dynamic_parameters(layout.target_hub)
            base = self.tree.joints[target_joint].inertia - L @ p[:10]
        set_(self, "target_joint", target_joint)
        set_(self, "target_map", _frozen(L))
        set_(self, "target_base", _frozen(base))
        if parameters is not None:
            p = check_parameters(names, parameters, layout.has_target)
        set_(self, "_p", _frozen(p))

    def parameters(self) -> np.ndarray:
        """The parameter vector ``p`` (a copy), named by :attr:`parameter_names`."""
        return self._p.copy()

    def with_parameters(self, p) -> "System":
        """The same system with another parameter vector (validated: DomainError naming the problem)."""
        return System(self.assembly, self.inputs, self.B if self.custom_input_matrix else None, parameters=p,
                      scenario=self.scenario)

    def with_updates(self, values: dict) -> "System":
        """The same system with some parameters set by name (``{"arm.stiffness_scale": 0.9}``)."""
        from postcapture.core.errors import DomainError

        if not values:
            return self
        p = self.parameters()
        for name, value in values.items():
            if name not in self.parameter_names:
                raise DomainError(f"parameters: expected names among {', '.join(self.parameter_names)}, found {name!r}")
            p[self.parameter_names.index(name)] = value
        return self.with_parameters(p)

    def with_inputs(self, inputs: InputSchedule, input_matrix=None) -> "System":
        """The same system under another input schedule (and input matrix)."""
        return System(self.assembly, inputs, input_matrix, parameters=self._p, scenario=self.scenario)

    def spring_coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """Each spring's stiffness and damper at the current scales."""
        sp, p = self.assembly.springs, self._p
        k = np.array([k0 * (p[i] if i >= 0 else 1.0) for k0, i in zip(sp.k, self.spring_k)])
        d = np.array([d0 * (p[i] if i >= 0 else 1.0) for d0, i in zip(sp.d, self.spring_d)])
        return k, d

    @property
    def K_e(self) -> np.ndarray:
        """``K_e = A^T diag(k) A`` (n_e x n_e) at the current scales; used by the modal analysis at rest."""
        A = self.assembly.springs.matrix(self.n_e)
        return A.T @ (self.spring_coefficients()[0][:, None] * A)

    @property
    def D_e(self) -> np.ndarray:
        """``D_e = A^T diag(d) A`` (n_e x n_e) at the current scales."""
        A = self.assembly.springs.matrix(self.n_e)
        return A.T @ (self.spring_coefficients()[1][:, None] * A)

    def joint_inertia(self, j: int) -> np.ndarray:
        """Joint ``j``'s body as ten dynamic parameters in its frame, at the current parameters."""
        if j == self.target_joint:
            return self.target_base + self.target_map @ self._p[:10]
        return self.tree.joints[j].inertia.copy()

    @property
    def target_mass(self) -> float:
        """Total target mass (kg), hub plus panels."""
        if not self.layout.has_target:
            raise AttributeError("this scenario has no target")
        return float(self._p[0]) + self.layout.target_panel_mass

    def with_target_mass(self, value: float) -> "System":
        """The same system with another total target mass (the hub's, at a fixed centre of mass and inertia)."""
        if not self.layout.has_target:
            raise AttributeError("this scenario has no target")
        return self.with_parameters(with_target_mass(self._p, value, self.layout.target_panel_mass))

    def dparams_dmass(self) -> np.ndarray:
        """``d p / d target_mass`` (n_p,): the hub's mass at a fixed centre of mass and inertia about it."""
        out = np.zeros(len(self.parameter_names))
        if self.layout.has_target:
            out[:10] = dmass_direction(self._p[:10])
        return out

    def copy(self) -> "System":
        """The system itself: it is immutable, so a copy has nothing to own."""
        return self

    # ------------------------------------------------------------------ inputs
    def input_vector(self, t: float, u_extra=None, left: bool = False) -> np.ndarray:
        """``u(t) + u_extra``, shape (n_u,); ``left`` takes the schedule's left limit at ``t``."""
        u = self.inputs(t, left)
        return u if u_extra is None else u + u_extra

    # ------------------------------------------------------------------ Lie group (the core's)
    def integrate(self, q, dq) -> np.ndarray:
        """``q (+) dq`` on the configuration group."""
        from postcapture.dynamics.liegroup import integrate

        return integrate(q, dq, self.nq, self.nv, self.layout.free_flyer)

    def difference(self, q0, q1) -> np.ndarray:
        """Tangent vector ``dq`` with ``q0 (+) dq = q1``."""
        from postcapture.dynamics.liegroup import difference

        return difference(q0, q1, self.nq, self.nv, self.layout.free_flyer)


def _rebuild(assembly, inputs, input_matrix, parameters, scenario) -> System:
    """Unpickle a :class:`System` (through its constructor: it is immutable)."""
    return System(assembly, inputs, input_matrix, parameters=parameters, scenario=scenario)
