"""The plant of a :class:`~postcapture.dynamics.system.System` as CasADi expressions.

Everything is read from the same assembled Pinocchio model the native simulation uses
(``model.joints``, ``jointPlacements``, ``inertias``, ``parents``, ``frames``), with the same springs
(``tau_e = A^T (k (r - A e) - d A de)``, i.e. ``tau0 - K_e e - D_e de``), the same input matrix
(``u = [F_B (3), tau_B (3), tau_arm (n_arm)]``) and the same target-mass parametrisation: the inertia
of the joint carrying the target is affine in the hub mass, ``pi(m) = pi_0 + (m - m_panels) pi_1``.

The forward dynamics is Featherstone's articulated-body algorithm in local joint frames with zero
gravity. Supported joints: a free flyer (the root) and revolute joints about x, y or z.

Parameter vector ``p = [target_mass (if any), k_1 .. k_ns, d_1 .. d_ns]`` (kg, N m/rad, N m s/rad).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.dynamics.system import System
from postcapture.fmi._extras import import_casadi
from postcapture.fmi.symbolic import spatial as sp
from postcapture.fmi.symbolic.liegroup import hamilton_xyzw, integrate_free_flyer

__all__ = ["Parameter", "OutputSignal", "SymbolicPlant"]

_REVOLUTE = {"JointModelRX": 0, "JointModelRY": 1, "JointModelRZ": 2}


@dataclass(frozen=True)
class Parameter:
    """One tunable parameter of the plant."""

    name: str
    value: float
    unit: str
    description: str
    min: float | None = None


@dataclass(frozen=True)
class OutputSignal:
    """One named scalar output (see :meth:`SymbolicPlant.outputs`)."""

    name: str
    unit: str
    description: str


class SymbolicPlant:
    """CasADi expressions of a built system's dynamics, kinematics and outputs.

    Parameters
    ----------
    system : System
        A system from :func:`postcapture.dynamics.build.build_system`; its current target mass
        becomes the default of the ``target_mass`` parameter.
    """

    def __init__(self, system: System):
        import pinocchio as pin

        self.system = system
        model = system.model
        self.model = model
        self.nq, self.nv, self.n_u = model.nq, model.nv, system.n_u
        self.nx = self.nq + self.nv
        self.free_flyer = system.layout.free_flyer
        self.n_root_q, self.n_root_v = system.n_root_q, system.n_root_v
        self.n_e = system.n_e
        self.layout = system.layout
        self.n_arm = system.layout.n_arm
        self.arm_v = np.asarray(system.layout.arm_v, dtype=int)
        self.motor_v = np.asarray(system.layout.motor_v, dtype=int)
        self.joints = []
        for i in range(1, model.njoints):
            name = model.joints[i].shortname()
            if name == "JointModelFreeFlyer":
                if model.parents[i] != 0:
                    raise ValueError(f"joint {model.names[i]!r}: a free flyer is only supported as the root")
                kind = -1
            elif name in _REVOLUTE:
                kind = _REVOLUTE[name]
            else:
                raise ValueError(
                    f"joint {model.names[i]!r}: unsupported joint type {name} (free flyer, RX, RY, RZ only)"
                )
            M = model.jointPlacements[i]
            self.joints.append(
                (
                    i,
                    int(model.parents[i]),
                    kind,
                    model.joints[i].idx_q,
                    model.joints[i].idx_v,
                    M.rotation.copy(),
                    M.translation.copy(),
                )
            )
        springs = system.assembly.springs
        self.spring_names = list(springs.names)
        self.A = springs.matrix(self.n_e)
        self.rest = np.asarray(springs.rest, dtype=float)
        params = []
        self.t_joint = None
        if system.layout.has_target:
            fid = model.getFrameId("target")
            frame = model.frames[fid]
            hub = system.layout.target_hub
            m_panels = system.layout.target_panel_mass
            m_hub = system.target_mass - m_panels
            X = frame.placement
            current = model.inertias[frame.parentJoint].toDynamicParameters()
            hub_now = X.act(pin.Inertia(m_hub, hub.com, hub.inertia)).toDynamicParameters()
            hub_c = X.act(pin.Inertia(0.0, hub.com, hub.inertia)).toDynamicParameters()
            self.t_joint = int(frame.parentJoint)
            self.t_pi0 = current - hub_now + hub_c  # everything but the hub's mass-proportional part
            self.t_pi1 = X.act(pin.Inertia(1.0, hub.com, np.zeros((3, 3)))).toDynamicParameters()
            self.t_panels = float(m_panels)
            params.append(
                Parameter(
                    "target_mass",
                    float(system.target_mass),
                    "kg",
                    "total target mass, hub plus panels (the hub mass changes at fixed CoM and inertia)",
                    min=float(m_panels),
                )
            )
        for name, k in zip(self.spring_names, springs.k, strict=True):
            params.append(Parameter(f"k_{name}", float(k), "N.m/rad", f"stiffness of spring {name}", min=0.0))
        for name, d in zip(self.spring_names, springs.d, strict=True):
            params.append(Parameter(f"d_{name}", float(d), "N.m.s/rad", f"damping of spring {name}", min=0.0))
        self.parameters = params
        self.n_p = len(params)
        self.has_target = self.t_joint is not None
        self._p_k0 = 1 if self.has_target else 0
        self._ns = len(self.spring_names)

    # ------------------------------------------------------------------ pieces
    def joint_transforms(self, q):
        """``{joint id: (R, p)}``: each joint frame in its parent joint frame at configuration ``q``."""
        ca = import_casadi()
        out = {}
        for i, _parent, kind, iq, _iv, Rp, pp in self.joints:
            Rn, pn = sp.numeric(Rp), sp.numeric(pp)
            if kind < 0:
                R = Rn @ sp.quat_to_matrix(q[iq + 3], q[iq + 4], q[iq + 5], q[iq + 6])
                p = pn + Rn @ q[iq : iq + 3]
            else:
                R = Rn @ sp.rot_axis(kind, ca.cos(q[iq]), ca.sin(q[iq]))
                p = pn
            out[i] = (R, p)
        return out

    def generalized_force(self, q, v, u, p):
        """``tau = springs(q, v; k, d) + B u`` (nv,)."""
        ca = import_casadi()
        tau = [ca.SX(0)] * self.nv
        if self.n_e:
            e = q[self.n_root_q :]
            de = v[self.n_root_v :]
            k = p[self._p_k0 : self._p_k0 + self._ns]
            d = p[self._p_k0 + self._ns : self._p_k0 + 2 * self._ns]
            A = self.A
            for j in range(self._ns):
                cols = np.nonzero(A[j])[0]
                delta = sum(A[j, c] * e[int(c)] for c in cols)
                rate = sum(A[j, c] * de[int(c)] for c in cols)
                f = k[j] * (self.rest[j] - delta) - d[j] * rate
                for c in cols:
                    tau[self.n_root_v + int(c)] = tau[self.n_root_v + int(c)] + A[j, c] * f
        if self.free_flyer:
            for r in range(6):
                tau[r] = tau[r] + u[r]
        for i, iv in enumerate(self.motor_v):
            tau[int(iv)] = tau[int(iv)] + u[6 + i]
        return ca.vertcat(*tau)

    def _inertia(self, joint: int, p):
        if joint == self.t_joint:
            m_hub = p[0] - self.t_panels
            params = [self.t_pi0[i] + m_hub * self.t_pi1[i] for i in range(10)]
            return sp.inertia_matrix(params)
        return sp.numeric(self.model.inertias[joint].matrix())

    # ------------------------------------------------------------------ dynamics
    def acceleration(self, q, v, u, p):
        """Generalised acceleration ``ddq`` (nv,) by the articulated-body algorithm."""
        ca = import_casadi()
        tau = self.generalized_force(q, v, u, p)
        X = self.joint_transforms(q)
        vel, bias, Ia, pA, info = {}, {}, {}, {}, {}
        for i, parent, kind, _iq, iv, _R, _p in self.joints:
            R, pos = X[i]
            if kind < 0:
                vi = v[iv : iv + 6]
                ci = ca.SX.zeros(6)
            else:
                vJ = ca.SX.zeros(6)
                vJ[3 + kind] = v[iv]
                vi = (sp.motion_act_inv(R, pos, vel[parent]) if parent > 0 else ca.SX.zeros(6)) + vJ
                ci = sp.cross_motion(vi, vJ)
            vel[i], bias[i] = vi, ci
            Ii = self._inertia(i, p)
            Ia[i] = Ii
            pA[i] = sp.cross_force(vi, Ii @ vi)
        for i, parent, kind, _iq, iv, _R, _p in reversed(self.joints):
            if kind < 0:
                continue
            U = Ia[i][:, 3 + kind]
            D = U[3 + kind]
            u_i = tau[iv] - pA[i][3 + kind]
            info[i] = (U, D, u_i)
            if parent > 0:
                Iaa = Ia[i] - (U @ U.T) / D
                pa = pA[i] + Iaa @ bias[i] + U * (u_i / D)
                R, pos = X[i]
                Ia[parent] = Ia[parent] + sp.transform_inertia(R, pos, Iaa)
                pA[parent] = pA[parent] + sp.force_act(R, pos, pa)
        ddq = [None] * self.nv
        acc = {}
        for i, parent, kind, _iq, iv, _R, _p in self.joints:
            if kind < 0:
                ai = sp.ldl_solve(Ia[i], tau[iv : iv + 6] - pA[i])
                for r in range(6):
                    ddq[iv + r] = ai[r]
            else:
                R, pos = X[i]
                U, D, u_i = info[i]
                ai = (sp.motion_act_inv(R, pos, acc[parent]) if parent > 0 else ca.SX.zeros(6)) + bias[i]
                qdd = (u_i - ca.dot(U, ai)) / D
                ddq[iv] = qdd
                ai[3 + kind] += qdd
            acc[i] = ai
        return ca.vertcat(*ddq)

    def integrate(self, q0, xi):
        """``q0 (+) xi`` on the configuration group (nq,)."""
        ca = import_casadi()
        parts = []
        if self.free_flyer:
            parts.append(integrate_free_flyer(q0[:7], xi[:6]))
        if self.n_e:
            parts.append(q0[self.n_root_q :] + xi[self.n_root_v :])
        return ca.vertcat(*parts)

    def state_derivative(self, q, v, ddq):
        """Ambient ``dx/dt`` (nx,) of ``x = [q, v]``: ``dp/dt = R v_lin``, ``dquat/dt = quat (w, 0) / 2``."""
        ca = import_casadi()
        parts = []
        if self.free_flyer:
            R = sp.quat_to_matrix(q[3], q[4], q[5], q[6])
            parts.append(R @ v[:3])
            parts.append(0.5 * hamilton_xyzw(q[3:7], ca.vertcat(v[3:6], 0)))
        if self.n_e:
            parts.append(v[self.n_root_v :])
        parts.append(ddq)
        return ca.vertcat(*parts)

    # ------------------------------------------------------------------ outputs
    def measurement(self, q, v, ddq):
        """``z = [accel_B (3), arm joint accelerations (n_arm)]``, zero for locked arm joints."""
        ca = import_casadi()
        if not self.free_flyer:
            raise ValueError("the measurement needs a free-flyer chaser")
        r = sp.numeric(self._accelerometer())
        w = v[3:6]
        acc = ddq[:3] + ca.cross(w, v[:3]) + ca.cross(ddq[3:6], r) + ca.cross(w, ca.cross(w, r))
        arm = [ddq[int(i)] for i in self.arm_v] + [ca.SX(0)] * (self.n_arm - self.arm_v.size)
        return ca.vertcat(acc, *arm)

    def _accelerometer(self) -> np.ndarray:
        model = self.model
        return model.frames[model.getFrameId("accelerometer")].placement.translation.copy()

    def output_signals(self) -> list[OutputSignal]:
        """Names, units and meanings of :meth:`outputs`, in order."""
        xyz = ("x", "y", "z")
        sig = [
            OutputSignal(
                f"q_BN_{c}", "1", f"chaser attitude quaternion q_BN, component {c} (scalar first, w >= 0)"
            )
            for c in ("w", "x", "y", "z")
        ]
        sig += [
            OutputSignal(f"omega_BN_B_{c}", "rad/s", f"chaser body rate, B relative to N, B component {c}")
            for c in xyz
        ]
        sig += [OutputSignal(f"r_BN_N_{c}", "m", f"chaser origin position in N, component {c}") for c in xyz]
        sig += [
            OutputSignal(
                f"accel_B_{c}", "m/s2", f"chaser acceleration at the accelerometer point, B component {c}"
            )
            for c in xyz
        ]
        for label, unit, what in (
            ("arm_q", "rad", "angle"),
            ("arm_dq", "rad/s", "rate"),
            ("arm_ddq", "rad/s2", "acceleration"),
        ):
            sig += [
                OutputSignal(
                    f"{label}_{i + 1}", unit, f"arm joint {i + 1} {what} (link side; zero when locked)"
                )
                for i in range(self.n_arm)
            ]
        for p in self.layout.panels:
            sig += [
                OutputSignal(
                    f"tip_{p.name}_{c}", "m", f"tip deflection of {p.name} in its root frame, component {c}"
                )
                for c in xyz
            ]
            sig.append(OutputSignal(f"torsion_{p.name}", "rad", f"root torsion angle of {p.name}"))
        return sig

    def outputs(self, q, v, ddq):
        """The named outputs of :meth:`output_signals` as one SX column."""
        ca = import_casadi()
        sign = ca.if_else(q[6] < 0, -1, 1)
        out = [sign * q[6], sign * q[3], sign * q[4], sign * q[5]]
        out += [v[3 + i] for i in range(3)] + [q[i] for i in range(3)]
        z = self.measurement(q, v, ddq)
        out += [z[i] for i in range(3)]
        locked = [ca.SX(0)] * (self.n_arm - self.arm_v.size)
        out += [q[int(i) + 1] for i in self.arm_v] + locked
        out += [v[int(i)] for i in self.arm_v] + locked
        out += [ddq[int(i)] for i in self.arm_v] + locked
        X = self.joint_transforms(q)
        model = self.model
        for p in self.layout.panels:
            root = model.frames[model.getFrameId(p.root_frame)]
            tip = model.frames[model.getFrameId(p.tip_frame)]
            R, pos = self._relative(X, int(root.parentJoint), int(tip.parentJoint))
            tip_in_host = pos + R @ sp.numeric(tip.placement.translation)
            Rr, pr = root.placement.rotation, root.placement.translation
            d = sp.numeric(Rr.T) @ (tip_in_host - sp.numeric(pr))
            out += [d[0] - p.length, d[1], d[2]]
            out.append(q[p.torsion_v + 1] if p.torsion_v is not None else ca.SX(0))
        return ca.vertcat(*out)

    def _relative(self, X, ancestor: int, joint: int):
        """Placement of ``joint`` in the frame of ``ancestor`` (an ancestor or the joint itself)."""
        ca = import_casadi()
        chain = []
        j = joint
        while j != ancestor:
            if j == 0:
                raise ValueError(f"joint {joint} does not descend from joint {ancestor}")
            chain.append(j)
            j = int(self.model.parents[j])
        M = (ca.SX.eye(3), ca.SX.zeros(3))
        for j in reversed(chain):
            M = sp.compose(M, X[j])
        return M

    def symbols(self):
        """Fresh symbols ``(q, v, u, p)``."""
        ca = import_casadi()
        return (
            ca.SX.sym("q", self.nq),
            ca.SX.sym("v", self.nv),
            ca.SX.sym("u", self.n_u),
            ca.SX.sym("p", self.n_p),
        )

    def parameter_values(self) -> np.ndarray:
        """Default parameter vector (the system's current values)."""
        return np.array([p.value for p in self.parameters])
