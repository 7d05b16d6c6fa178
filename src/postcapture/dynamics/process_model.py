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
from postcapture.dynamics.parameters import dmass_direction
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
        self._system = system.copy()
        self._integrator_name = integrator
        self._newton: tuple | None = None
        self.step = float(step)
        self.name = name
        self.plant = CompiledPlant(self._system, integrator)
        self._p = self._system.parameters()  # the model's parameters (the compiled copy holds them)
        self._system_p = self._p.copy()  # what the System holds
        sysm = self._system
        self.nq, self.nv = sysm.nq, sysm.nv
        self.nx = self.nq + self.nv
        self.n = 2 * self.nv
        self.n_meas = self.plant.nz
        self.tangent_attitude = slice(3, 6)
        self.tangent_velocity = slice(self.nv, self.nv + 3)
        self.tangent_rate = slice(self.nv + 3, self.nv + 6)
        self.tangent_arm = np.array(sysm.layout.arm_v, dtype=int)
        self._arm_q = self.tangent_arm + (self.nq - self.nv)
        self.accelerometer_position = np.array(sysm.scenario.chaser.accelerometer_position, dtype=float)
        self._panel_mass = sysm.layout.target_panel_mass if sysm.layout.has_target else 0.0

    # ------------------------------------------------------------------ parameters
    # The compiled copy holds the parameters; the System it was built from (the Pinocchio model and
    # springs: the initial state, parameter validation) follows lazily, and changes made on it directly
    # are taken up at the next call.
    def _current(self) -> np.ndarray:
        sp = self._system._p
        if not np.array_equal(sp, self._system_p):  # set on `system` directly
            self._p, self._system_p = sp.copy(), sp.copy()
            self.plant.set_params(self._p)
        return self._p

    def copy(self) -> "NativeProcessModel":
        """An independent copy (own system, parameters, compiled plant and Newton settings): a filter's own plant."""
        other = NativeProcessModel(self.system, self.step, self._integrator_name, self.name)
        if self._newton is not None:
            other.set_newton(*self._newton)
        return other

    @property
    def system(self) -> System:
        """The plant's description (:class:`System`: Pinocchio model, springs, inputs) at the model's
        current parameters."""
        self._current()
        if not np.array_equal(self._system_p, self._p):
            self._system.set_parameters(self._p)
            self._system_p = self._p.copy()
        return self._system

    @property
    def param_names(self) -> tuple[str, ...]:
        """Names of the parameter vector (:mod:`postcapture.dynamics.parameters`)."""
        return self._system.parameter_names

    @property
    def params(self) -> np.ndarray:
        """The model's parameter vector (a copy)."""
        return self._current().copy()

    def set_params(self, p) -> None:
        """Set the model's parameter vector (the filter's estimate of the truth's); validated by the system."""
        self._current()
        self._system.set_parameters(p)
        self._p, self._system_p = self._system.parameters(), self._system.parameters()
        self.plant.set_params(self._p)

    def set_newton(self, rtol: float, atol: float, max_iter: int = 12) -> None:
        """Newton acceptance of the implicit stages (default 1e-10 relative, 1e-15 absolute)."""
        self.plant.set_newton(rtol, atol, max_iter)
        self._newton = (rtol, atol, max_iter)

    def _dparams_dmass(self) -> np.ndarray:
        out = np.zeros(self._p.size)
        out[:10] = dmass_direction(self._p[:10])
        return out

    @property
    def mass(self) -> float:
        if not self._system.layout.has_target:
            raise AttributeError("this scenario has no target")
        return float(self._current()[0]) + self._panel_mass

    @mass.setter
    def mass(self, value: float) -> None:
        """The hub's mass changes at a fixed centre of mass and inertia about it (linear in the mass)."""
        if not self._system.layout.has_target:
            raise AttributeError("this scenario has no target")
        m_hub = float(value) - self._panel_mass
        if not m_hub > 0.0:
            raise ValueError(f"target_mass: expected more than the panels' {self._panel_mass} kg, found {value}")
        p = self._current().copy()
        p += (m_hub - p[0]) * self._dparams_dmass()
        p[0] = m_hub
        self.plant.set_params(p)
        self._p = p

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
        self._current()
        q1, v1, z, F, _Fu, G, H, _Hu, Hp = self.plant.predict(q, v, t, self.step, k, jacobians)
        g = h = None
        if jacobians:
            dpdm = self._dparams_dmass() if self._system.layout.has_target else np.zeros(G.shape[1])
            g, h = G @ dpdm, Hp @ dpdm
        return Prediction(np.concatenate([q1, v1]), z, F, g, H, h, G, Hp)

    def retract(self, x, dx):
        q, v = self.split(np.asarray(x, dtype=float))
        return np.concatenate([pin.integrate(self._system.model, q, dx[: self.nv]), v + dx[self.nv :]])

    def local(self, x1, x0):
        q1, v1 = self.split(np.asarray(x1, dtype=float))
        q0, v0 = self.split(np.asarray(x0, dtype=float))
        return np.concatenate([pin.difference(self._system.model, q0, q1), v1 - v0])

    def attitude(self, x) -> np.ndarray:
        return quat_from_pinocchio(np.asarray(x[3:7], dtype=float))

    def body_rate(self, x) -> np.ndarray:
        return np.asarray(x[self.nq + 3 : self.nq + 6], dtype=float)

    def chaser_velocity(self, x) -> np.ndarray:
        """Velocity of B's origin (the chaser's centre of mass), body components (m/s)."""
        return np.asarray(x[self.nq : self.nq + 3], dtype=float)

    def arm_angles(self, x) -> np.ndarray:
        """The arm's link-side joint angles (rad), what its encoders read."""
        return np.asarray(x[self._arm_q], dtype=float)
