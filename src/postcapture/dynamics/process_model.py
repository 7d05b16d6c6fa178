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

    Returns ``z`` (m,), ``H`` (m, 2nv) with respect to the tangent ``(dq, dv)``, and ``h`` (m,) with
    respect to the target mass (None without a target).
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
    h = None
    if system.layout.has_target:
        dm = system.ddq_dmass(q, v, ddq, Minv)
        h = np.concatenate([J_ddq @ dm[:6], dm[arm_v]])
    return z, H, h


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

    def initial_state(self) -> np.ndarray:
        from postcapture.dynamics.build import initial_state

        q0, v0 = initial_state(self.system)
        return np.concatenate([q0, v0])

    def split(self, x):
        """``(q, v)`` views of a state vector."""
        return x[: self.nq], x[self.nq :]

    def _measure(self, q, v, t, jacobians):
        if jacobians:
            z, H, h = measurement_jacobian(self.system, q, v, t, self._r_acc, self._arm_v)
        else:
            ddq = self.system.acceleration(q, v, t)
            z = np.concatenate([accelerometer_reading(v, ddq, self._r_acc), ddq[self._arm_v]])
            H = h = None
        if self._n_arm_locked:  # locked joints measure zero acceleration
            z = np.concatenate([z, np.zeros(self._n_arm_locked)])
            if H is not None:
                H = np.vstack([H, np.zeros((self._n_arm_locked, self.n))])
                h = np.concatenate([h, np.zeros(self._n_arm_locked)]) if h is not None else None
        return z, H, h

    def predict(self, x, t: float, dt: float, jacobians: bool = False):
        k = int(round(dt / self.step))
        if k < 1 or abs(k * self.step - dt) > 1e-9 * max(1.0, dt):
            raise ValueError(f"dt: expected a whole multiple of the model step {self.step}, found {dt}")
        q, v = self.split(np.asarray(x, dtype=float))
        F = g = None
        for j in range(k):
            tj = t + j * self.step
            if jacobians:
                res = self.integrator.step_jacobian(q, v, tj, self.step)
                q, v = res.q, res.v
                gm = res.Fm if res.Fm is not None else np.zeros(self.n)
                if F is None:
                    F, g = res.Fx, gm
                else:
                    F, g = res.Fx @ F, res.Fx @ g + gm
            else:
                q, v = self.integrator.step(q, v, tj, self.step)
        z, H, h = self._measure(q, v, t + dt, jacobians)
        return Prediction(np.concatenate([q, v]), z, F, g, H, h)

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
