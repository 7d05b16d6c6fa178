"""The native process model: a :class:`System` behind the filters' ProcessModel protocol.

It satisfies :class:`postcapture.estimation.process.ProcessModel` structurally (no import upward).
State ``x = [q (nq), v (nv)]``; tangent ``[dq (nv), dv (nv)]`` with right perturbations of ``q``, so the
attitude error is ``dq[3:6]`` (body frame) and the body-rate error ``dv[3:6]``.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from postcapture.core.prediction import Prediction
from postcapture.core.rotations import skew
from postcapture.dynamics.integrators import make_integrator
from postcapture.dynamics.outputs import accelerometer_reading
from postcapture.dynamics.system import System

__all__ = ["NativeProcessModel", "measurement_jacobian"]


def measurement_jacobian(system: System, q, v, t: float, r_acc: np.ndarray, arm_v: np.ndarray):
    """Measurement ``z = [accel_B, arm_ddq]`` at ``(q, v, t)`` and its exact derivatives.

    Returns ``z`` (m,), ``H`` (m, 2nv) with respect to the tangent ``(dq, dv)``, and ``Hp`` (m, n_p) with
    respect to the system's parameter vector.
    """
    nv = system.nv
    u = system.input_vector(t)
    ddq, Aq, Av, Minv = system.derivatives_u(q, v, u)
    w, vl = v[3:6], v[:3]
    z = np.concatenate([accelerometer_reading(v, ddq, r_acc), ddq[arm_v]])
    # accel = ddq[:3] + w x vl + wd x r + w x (w x r)
    J_ddq = np.hstack([np.eye(3), -skew(r_acc)])  # d accel / d ddq[0:6]
    d_w = -skew(vl) + np.outer(w, r_acc) + (w @ r_acc) * np.eye(3) - 2.0 * np.outer(r_acc, w)
    H = np.zeros((z.size, 2 * nv))
    H[:3, :nv] = J_ddq @ Aq[:6]
    H[:3, nv:] = J_ddq @ Av[:6]
    H[:3, nv : nv + 3] += skew(w)
    H[:3, nv + 3 : nv + 6] += d_w
    H[3:, :nv] = Aq[arm_v]
    H[3:, nv:] = Av[arm_v]
    dp = system.ddq_dparams(q, v, ddq, Minv)
    Hp = np.vstack([J_ddq @ dp[:6], dp[arm_v]])
    return z, H, Hp


class NativeProcessModel:
    """A filter's own copy of the plant (own Pinocchio model and data, own target mass).

    Parameters
    ----------
    system : System
        The plant; it is copied, so the filter's mass never touches the truth.
    step : float
        Integrator step (s); a filter step ``dt`` must be a whole multiple of it.
    integrator : str
        Integrator name (default ``"sdirk3"``).
    name : str
        Label for logs and results.
    """

    def __init__(self, system: System, step: float, integrator: str = "sdirk3", name: str = "native"):
        self.system = system.copy()
        self.step = float(step)
        self.integrator = make_integrator(self.system, integrator)
        self.name = name
        sysm = self.system
        self.nq, self.nv = sysm.nq, sysm.nv
        self.nx = self.nq + self.nv
        self.n = 2 * self.nv
        n_arm = sysm.layout.n_arm
        self.n_meas = 3 + n_arm
        self.tangent_attitude = slice(3, 6)
        self.tangent_rate = slice(self.nv + 3, self.nv + 6)
        model = sysm.model
        self._r_acc = model.frames[model.getFrameId("accelerometer")].placement.translation.copy()
        self._arm_v = np.asarray(sysm.layout.arm_v, dtype=int)
        self._n_arm_locked = n_arm - self._arm_v.size  # the rigid variant has no arm coordinates

    # ------------------------------------------------------------------ protocol
    @property
    def mass(self) -> float:
        return self.system.target_mass

    @mass.setter
    def mass(self, value: float) -> None:
        self.system.target_mass = value

    @property
    def param_names(self) -> tuple[str, ...]:
        """Names of the parameter vector (:mod:`postcapture.dynamics.parameters`)."""
        return self.system.parameter_names

    @property
    def params(self) -> np.ndarray:
        """The model's parameter vector (a copy)."""
        return self.system.parameters()

    def set_params(self, p) -> None:
        """Set the model's parameter vector (the filter's estimate of the truth's)."""
        self.system.set_parameters(p)

    def initial_state(self) -> np.ndarray:
        from postcapture.dynamics.build import initial_state

        q0, v0 = initial_state(self.system)
        return np.concatenate([q0, v0])

    def split(self, x):
        """``(q, v)`` views of a state vector."""
        return x[: self.nq], x[self.nq :]

    def _measure(self, q, v, t, jacobians):
        if jacobians:
            z, H, Hp = measurement_jacobian(self.system, q, v, t, self._r_acc, self._arm_v)
        else:
            ddq = self.system.acceleration(q, v, t)
            z = np.concatenate([accelerometer_reading(v, ddq, self._r_acc), ddq[self._arm_v]])
            H = Hp = None
        if self._n_arm_locked:  # locked joints measure zero acceleration
            z = np.concatenate([z, np.zeros(self._n_arm_locked)])
            if H is not None:
                H = np.vstack([H, np.zeros((self._n_arm_locked, self.n))])
                Hp = np.vstack([Hp, np.zeros((self._n_arm_locked, Hp.shape[1]))])
        return z, H, Hp

    def predict(self, x, t: float, dt: float, jacobians: bool = False):
        k = int(round(dt / self.step))
        if k < 1 or abs(k * self.step - dt) > 1e-9 * max(1.0, dt):
            raise ValueError(f"dt: expected a whole multiple of the model step {self.step}, found {dt}")
        q, v = self.split(np.asarray(x, dtype=float))
        F = G = None
        for j in range(k):
            tj = t + j * self.step
            if jacobians:
                res = self.integrator.step_jacobian(q, v, tj, self.step)
                q, v = res.q, res.v
                if F is None:
                    F, G = res.Fx, res.Fp
                else:
                    F, G = res.Fx @ F, res.Fx @ G + res.Fp
            else:
                q, v = self.integrator.step(q, v, tj, self.step)
        z, H, Hp = self._measure(q, v, t + dt, jacobians)
        g = h = None
        if jacobians:
            dpdm = self.system.dparams_dmass() if self.system.layout.has_target else np.zeros(G.shape[1])
            g, h = G @ dpdm, Hp @ dpdm
        return Prediction(np.concatenate([q, v]), z, F, g, H, h, G, Hp)

    def retract(self, x, dx):
        q, v = self.split(np.asarray(x, dtype=float))
        return np.concatenate([pin.integrate(self.system.model, q, dx[: self.nv]), v + dx[self.nv :]])

    def local(self, x1, x0):
        q1, v1 = self.split(np.asarray(x1, dtype=float))
        q0, v0 = self.split(np.asarray(x0, dtype=float))
        return np.concatenate([pin.difference(self.system.model, q0, q1), v1 - v0])

    def attitude(self, x) -> np.ndarray:
        q = x[3:7]
        s = -1.0 if q[3] < 0 else 1.0
        return s * np.array([q[3], q[0], q[1], q[2]])

    def body_rate(self, x) -> np.ndarray:
        return np.asarray(x[self.nq + 3 : self.nq + 6], dtype=float)
