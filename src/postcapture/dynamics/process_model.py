"""The native process model: the compiled plant core behind the filters' ProcessModel protocol.

It satisfies :class:`postcapture.estimation.process.ProcessModel` structurally (no import upward).
State ``x = [q (nq), v (nv)]``; tangent ``[dq (nv), dv (nv)]`` with right perturbations of ``q``, so the
attitude error is ``dq[3:6]`` (body frame) and the body-rate error ``dv[3:6]``. One :meth:`predict`
is one call of the core: the steps, the measurement and, on request, every Jacobian.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from postcapture.core.prediction import Prediction
from postcapture.core.rotations import quat_from_pinocchio
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.system import System

__all__ = ["NativeProcessModel"]


class NativeProcessModel:
    """A filter's own copy of the plant (own model, own parameters and target mass).

    Parameters
    ----------
    system : System
        The plant; it is copied, so the filter's parameters never touch the truth.
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
        self.name = name
        self.plant = CompiledPlant(self.system, integrator)
        self._synced = self.system.parameters()
        sysm = self.system
        self.nq, self.nv = sysm.nq, sysm.nv
        self.nx = self.nq + self.nv
        self.n = 2 * self.nv
        self.n_meas = self.plant.nz
        self.tangent_attitude = slice(3, 6)
        self.tangent_rate = slice(self.nv + 3, self.nv + 6)

    # ------------------------------------------------------------------ parameters
    # The Python system copy validates every change and keeps the initial state in step; the compiled
    # plant copy takes the same vector.
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
        self._sync()

    def _sync(self) -> None:
        """Give the compiled copy the Python copy's parameters (which may also be set on ``self.system``)."""
        p = self.system.parameters()
        if self._synced is None or not np.array_equal(p, self._synced):
            self.plant.set_params(p)
            self._synced = p

    def set_newton(self, rtol: float, atol: float, max_iter: int = 12) -> None:
        """Newton acceptance of the implicit stages (default 1e-10 relative, 1e-15 absolute)."""
        self.plant.set_newton(rtol, atol, max_iter)

    @property
    def mass(self) -> float:
        return self.system.target_mass

    @mass.setter
    def mass(self, value: float) -> None:
        self.system.target_mass = value
        self._sync()

    # ------------------------------------------------------------------ protocol
    def initial_state(self) -> np.ndarray:
        from postcapture.dynamics.build import initial_state

        q0, v0 = initial_state(self.system)
        return np.concatenate([q0, v0])

    def split(self, x):
        """``(q, v)`` views of a state vector."""
        return x[: self.nq], x[self.nq :]

    def predict(self, x, t: float, dt: float, jacobians: bool = False):
        k = int(round(dt / self.step))
        if k < 1 or abs(k * self.step - dt) > 1e-9 * max(1.0, dt):
            raise ValueError(f"dt: expected a whole multiple of the model step {self.step}, found {dt}")
        q, v = self.split(np.asarray(x, dtype=float))
        self._sync()
        q1, v1, z, F, _Fu, G, H, _Hu, Hp = self.plant.predict(q, v, t, self.step, k, jacobians)
        g = h = None
        if jacobians:
            dpdm = self.system.dparams_dmass() if self.system.layout.has_target else np.zeros(G.shape[1])
            g, h = G @ dpdm, Hp @ dpdm
        return Prediction(np.concatenate([q1, v1]), z, F, g, H, h, G, Hp)

    def retract(self, x, dx):
        q, v = self.split(np.asarray(x, dtype=float))
        return np.concatenate([pin.integrate(self.system.model, q, dx[: self.nv]), v + dx[self.nv :]])

    def local(self, x1, x0):
        q1, v1 = self.split(np.asarray(x1, dtype=float))
        q0, v0 = self.split(np.asarray(x0, dtype=float))
        return np.concatenate([pin.difference(self.system.model, q0, q1), v1 - v0])

    def attitude(self, x) -> np.ndarray:
        return quat_from_pinocchio(np.asarray(x[3:7], dtype=float))

    def body_rate(self, x) -> np.ndarray:
        return np.asarray(x[self.nq + 3 : self.nq + 6], dtype=float)
