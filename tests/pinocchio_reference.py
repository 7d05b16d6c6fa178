"""The plant's equations written with Pinocchio: the tests' independent reference of the compiled core.

The package computes the plant's dynamics once, in the compiled core (``postcapture/dynamics/csrc``,
:class:`postcapture.dynamics.core.CompiledPlant`), and never imports Pinocchio. This module, outside the
package, writes the same equations a second way, from a :class:`~postcapture.dynamics.system.System`'s
public description (its joint tree, springs, input matrix ``B`` and parameter vector) turned into a
Pinocchio model (:func:`pin_model`), and Pinocchio's algorithms (``aba``, ``computeABADerivatives``,
``bodyRegressor``), so that the core can be checked against it. :func:`scenario_model` builds a
scenario's tree a second way too, with Pinocchio's own API (joints, frames, ``SE3`` products,
``Inertia.act``, ``buildReducedModel``), to hold the package's plain-numpy tree builder to it.

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
    "pin_model", "pin_data", "scenario_model", "Springs", "springs", "spring_torque", "generalized_force", "acceleration", "acceleration_u", "derivatives",
    "derivatives_u", "ddq_dparams", "ddq_dmass", "elastic_energy", "kinetic_energy",
]


_PIN_KINDS = {"free_flyer": pin.JointModelFreeFlyer, "rx": pin.JointModelRX, "ry": pin.JointModelRY,
              "rz": pin.JointModelRZ}


def _pin_inertia(pi) -> pin.Inertia:
    """Pinocchio's inertia of ten dynamic parameters (a massless body, e.g. a rotor, has no centre of mass)."""
    if pi[0] != 0.0:
        return pin.Inertia.FromDynamicParameters(np.asarray(pi, dtype=float))
    I = np.array([[pi[4], pi[5], pi[7]], [pi[5], pi[6], pi[8]], [pi[7], pi[8], pi[9]]])
    return pin.Inertia(0.0, np.zeros(3), I)


def pin_model(system: System) -> pin.Model:
    """A Pinocchio model of the system's tree at its parameter vector (no gravity; frames as OP_FRAMEs)."""
    model = pin.Model()
    model.gravity = pin.Motion.Zero()
    for j, J in enumerate(system.tree.joints):
        jid = model.addJoint(J.parent + 1, _PIN_KINDS[J.kind](), pin.SE3(J.rotation.copy(), J.translation.copy()), J.name)
        model.appendBodyToJoint(jid, _pin_inertia(system.joint_inertia(j)), pin.SE3.Identity())
    for f in system.tree.frames:
        model.addFrame(pin.Frame(f.name, f.joint + 1, 0, pin.SE3(f.rotation.copy(), f.translation.copy()),
                                 pin.FrameType.OP_FRAME))
    return model


_MODELS: dict[int, tuple] = {}


def pin_data(system: System):
    """``(model, data)`` of :func:`pin_model`, kept per system (a System is immutable)."""
    key = id(system)
    if key not in _MODELS or _MODELS[key][0] is not system:
        model = pin_model(system)
        _MODELS[key] = (system, model, model.createData())
        while len(_MODELS) > 64:  # perturbed copies of finite-difference loops: keep the recent ones
            _MODELS.pop(next(iter(_MODELS)))
    return _MODELS[key][1], _MODELS[key][2]


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
    n_p = len(system.parameter_names)
    S_k, S_d = np.zeros((len(sp.k), n_p)), np.zeros((len(sp.k), n_p))  # which parameter scales each spring
    for j, (ik, id_) in enumerate(zip(system.spring_k, system.spring_d)):
        if ik >= 0:
            S_k[j, ik] = 1.0
        if id_ >= 0:
            S_d[j, id_] = 1.0
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
    model, data = pin_data(system)
    return pin.aba(model, data, q, v, force_from_inputs(system, q, v, u, sp))


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
    model, data = pin_data(system)
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
        (model, data), j = pin_data(system), system.target_joint + 1
        pin.forwardKinematics(model, data, q, v, ddq)
        J = pin.computeJointJacobian(model, data, q, j)
        Y = pin.bodyRegressor(data.v[j], data.a[j])
        out[:, :10] = -Minv @ (J.T @ (Y @ system.target_map))
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
    model, data = pin_data(system)
    return float(pin.computeKineticEnergy(model, data, q, v))



# ---------------------------------------------------------------------- the scenario's tree, by Pinocchio
def _se3(R, p) -> pin.SE3:
    return pin.SE3(np.asarray(R, dtype=float), np.asarray(p, dtype=float))


def _pose(pose) -> pin.SE3:
    return _se3(pose.rotation(), pose.translation())


def _inertia(props) -> pin.Inertia:
    return pin.Inertia(props.mass, props.com, props.inertia)


class _PinBuilder:
    """The tree of ``postcapture.dynamics.assembly``, written with Pinocchio's own API (the former builder)."""

    def __init__(self, scenario):
        self.sc = scenario
        self.model = pin.Model()
        self.model.gravity = pin.Motion.Zero()
        self.rest: dict[int, float] = {}
        self.body_frame: dict[int, int] = {0: 0}  # joint id -> its body frame (the universe's is 0)

    def joint(self, parent, jmodel, placement, name, inertia=None) -> int:
        m = self.model
        jid = m.addJoint(parent, jmodel, placement, name)
        fid = m.addJointFrame(jid, self.body_frame.get(parent, 0))
        if inertia is not None:
            m.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
        self.body_frame[jid] = m.addBodyFrame(name + "_body", jid, pin.SE3.Identity(), fid)
        return jid

    def frame(self, name, joint, placement) -> None:
        self.model.addFrame(pin.Frame(name, joint, self.body_frame[joint], placement, pin.FrameType.OP_FRAME))

    def panel(self, host, mount, panel) -> None:
        from postcapture.dynamics.bodies import segment_properties

        n, l = panel.segments, panel.length / panel.segments
        seg = _inertia(segment_properties(panel))
        self.frame(f"{panel.name}_root", host, mount)
        parent = self.joint(host, pin.JointModelRX(), mount, f"{panel.name}_torsion")
        for i in range(n):
            parent = self.joint(parent, pin.JointModelRY(), _se3(np.eye(3), [l if i else 0.0, 0, 0]),
                                f"{panel.name}_bend_{i + 1}", seg)
        self.frame(f"{panel.name}_tip", parent, _se3(np.eye(3), [l, 0.0, 0.0]))

    def hub(self, body, where):
        from postcapture.dynamics.bodies import MassProperties, hub_properties, panel_properties

        mounts = [(p.mount.rotation(), p.mount.translation(), panel_properties(p)) for p in body.panels]
        if body.properties_include_panels:
            return hub_properties(body.mass, body.inertia, mounts, where)
        return MassProperties(body.mass, np.zeros(3), body.inertia)

    def arm(self, root) -> int:
        axes = {"x": pin.JointModelRX, "y": pin.JointModelRY, "z": pin.JointModelRZ}
        parent = root
        for i, js in enumerate(self.sc.arm.joints):
            placement = _pose(js.origin) if i else _pose(self.sc.arm.base) * _pose(js.origin)
            if js.rotor_inertia is not None:
                axis = np.eye(3)["xyz".index(js.axis)]
                rotor = self.joint(parent, axes[js.axis](), placement, f"arm_{i + 1}_rotor",
                                   pin.Inertia(0.0, np.zeros(3), js.rotor_inertia * np.outer(axis, axis)))
                self.rest[rotor] = js.rest_angle
            link = pin.Inertia(js.mass, np.asarray(js.com, dtype=float), np.asarray(js.inertia, dtype=float))
            parent = self.joint(parent, axes[js.axis](), placement, f"arm_{i + 1}", link)
            self.rest[parent] = js.rest_angle
        return parent

    def build(self):
        sc = self.sc
        root = self.joint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "chaser", _inertia(self.hub(sc.chaser, "chaser")))
        self.frame("accelerometer", root, _se3(np.eye(3), sc.chaser.accelerometer_position))
        for p in sc.chaser.panels:
            self.panel(root, _pose(p.mount), p)
        if sc.arm is not None:
            last = self.arm(root)
            tool = _pose(sc.arm.tool)
            self.frame("grasp", last, tool)
            if sc.target is not None:
                X_JT = tool * _pose(sc.target.grasp_to_com)
                self.model.appendBodyToJoint(last, X_JT.act(_inertia(self.hub(sc.target, "target"))), pin.SE3.Identity())
                self.frame("target", last, X_JT)
                for p in sc.target.panels:
                    self.panel(last, X_JT * _pose(p.mount), p)
        q_rest = pin.neutral(self.model)
        for jid, angle in self.rest.items():
            q_rest[self.model.joints[jid].idx_q] = angle
        return self.model, q_rest


def scenario_model(scenario, variant: str = "flexible") -> tuple[pin.Model, np.ndarray]:
    """The scenario's tree built with Pinocchio's API (``rigid``: ``buildReducedModel`` at rest) and its rest
    configuration."""
    model, q_rest = _PinBuilder(scenario).build()
    if variant == "rigid":
        model = pin.buildReducedModel(model, list(range(2, model.njoints)), q_rest)
        model.gravity = pin.Motion.Zero()
        q_rest = pin.neutral(model)
    return model, q_rest
