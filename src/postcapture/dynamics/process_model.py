"""The native process model: the compiled plant core behind the filters' ProcessModel protocol.

It satisfies :class:`postcapture.estimation.process.ProcessModel` structurally (no import upward).
State ``x = [q (nq), v (nv)]``; tangent ``[dq (nv), dv (nv)]`` with right perturbations of ``q``, so the
attitude error is ``dq[3:6]`` (body frame) and the body-rate error ``dv[3:6]``. One :meth:`predict`
is one call of the core: the steps, the measurement and, on request, every Jacobian.
"""

from __future__ import annotations

import numpy as np

from postcapture.core.prediction import Prediction
from postcapture.core.rotations import quat_from_pinocchio
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.parameters import check_parameters, dmass_direction, with_target_mass
from postcapture.dynamics.system import System

__all__ = ["NativeProcessModel"]


class NativeProcessModel:
    """A filter's own plant: its own instance (parameters, warm start) over a constant compiled model.

    Parameters
    ----------
    system : System
        The plant's description (immutable; its parameter vector is where this model starts).
    step : float
        Integrator step (s); a filter step ``dt`` must be a whole multiple of it.
    integrator : str
        Integrator name (default ``"sdirk3"``).
    name : str
        Label for logs and results.
    jacobian : str
        Over a prediction of k steps: ``"every_step"`` chains each step's exact Jacobian, ``"first_step"``
        takes the first step's k times (one step's sensitivities; the state still takes every step; see
        ``[estimation] jacobian``).

    The parameters have one owner: this model's instance in the compiled core (:attr:`plant`).
    :meth:`copy` makes another instance over the same constant model, sharing nothing mutable.
    """

    def __init__(self, system: System, step: float, integrator: str = "sdirk3", name: str = "native", *,
                 plant: CompiledPlant | None = None, jacobian: str = "every_step"):
        from postcapture.dynamics.stability import check_step

        self._description = system
        self._integrator_name = integrator
        self.step = float(step)
        self.name = name
        if jacobian not in ("every_step", "first_step"):
            raise ValueError(f"jacobian: expected 'every_step' or 'first_step', found {jacobian!r}")
        self.jacobian = jacobian
        self.plant = CompiledPlant(system, integrator) if plant is None else plant
        if plant is None:
            check_step(self.plant, system.assembly.q_rest, np.zeros(system.nv), self.step)
        self.nq, self.nv = system.nq, system.nv
        self.nx = self.nq + self.nv
        self.n = 2 * self.nv
        self.n_meas = self.plant.nz
        self.tangent_attitude = slice(3, 6)
        self.tangent_velocity = slice(self.nv, self.nv + 3)
        self.tangent_rate = slice(self.nv + 3, self.nv + 6)
        self.tangent_arm = np.array(system.layout.arm_v, dtype=int)
        self._arm_q = self.tangent_arm + (self.nq - self.nv)
        self.accelerometer_position = np.array(system.scenario.chaser.accelerometer_position, dtype=float)
        self._panel_mass = system.layout.target_panel_mass if system.layout.has_target else 0.0

    @classmethod
    def for_filters(cls, scenario, system: System | None = None, *, variant: str = "flexible", side: str = "filters",
                    name: str = "native") -> "NativeProcessModel":
        """The filters' process model of a scenario: its ``[estimation]`` integrator, model step and Jacobian,
        the orbit's gravity gradient as ``[orbit] filters`` says (``side = "truth"``: always), on ``system``
        (built from the scenario by default)."""
        from postcapture.config.schema import orbit_mean_motion
        from postcapture.dynamics.build import build_system

        est = scenario.estimation
        model = cls(build_system(scenario, variant) if system is None else system, est.model_step, est.integrator,
                    name=name, jacobian=est.jacobian)
        n = orbit_mean_motion(scenario, side)
        if n:
            model.plant.set_orbit(n)
        return model

    def copy(self) -> "NativeProcessModel":
        """An independent copy (own instance: parameters, Newton settings, warm start) over the same
        constant model: a filter's own plant."""
        return NativeProcessModel(self._description, self.step, self._integrator_name, self.name,
                                  plant=self.plant.copy(), jacobian=self.jacobian)  # the instance's orbit too (pc_data_copy)

    def engine_handles(self):
        """This model's ``(pc_model_t*, pc_data_t*)`` in the compiled engine, for a filter that runs over its
        instance there (:class:`~postcapture.estimation.augmented.AugmentedEKF`; the filter keeps the model)."""
        return self.plant.model.handle, self.plant._d

    # ------------------------------------------------------------------ parameters
    @property
    def system(self) -> System:
        """The plant's description at this model's current parameters (immutable; a new one per call)."""
        return self._description.with_parameters(self.plant.params)

    @property
    def param_names(self) -> tuple[str, ...]:
        """Names of the parameter vector (:mod:`postcapture.dynamics.parameters`)."""
        return self._description.parameter_names

    @property
    def params(self) -> np.ndarray:
        """The model's parameter vector (a copy)."""
        return self.plant.params

    def set_params(self, p) -> None:
        """Set the model's parameter vector (the filter's estimate of the truth's); refused with a
        DomainError naming the problem when not physical (checked again by the core)."""
        self.plant.set_params(check_parameters(self.param_names, p, self._description.layout.has_target))

    def update_params(self, values: dict) -> None:
        """Set some parameters by name (``{"arm.stiffness_scale": 0.9}``), the others unchanged."""
        self.plant.set_params(self.system.with_updates(values).parameters())

    def set_newton(self, rtol: float, atol: float, max_iter: int = 12) -> None:
        """Newton acceptance of the implicit stages (default 1e-10 relative, 1e-15 absolute)."""
        self.plant.set_newton(rtol, atol, max_iter)

    def _dparams_dmass(self, p: np.ndarray) -> np.ndarray:
        out = np.zeros(p.size)
        out[:10] = dmass_direction(p[:10])
        return out

    @property
    def mass(self) -> float:
        if not self._description.layout.has_target:
            raise AttributeError("this scenario has no target")
        return float(self.plant.params[0]) + self._panel_mass

    @mass.setter
    def mass(self, value: float) -> None:
        """The hub's mass changes at a fixed centre of mass and inertia about it."""
        if not self._description.layout.has_target:
            raise AttributeError("this scenario has no target")
        self.plant.set_params(with_target_mass(self.plant.params, value, self._panel_mass))

    # ------------------------------------------------------------------ protocol
    def initial_state(self) -> np.ndarray:
        from postcapture.dynamics.build import initial_state

        q0, v0 = initial_state(self._description, plant=self.plant)
        return np.concatenate([q0, v0])

    def split(self, x):
        """``(q, v)`` views of a state vector."""
        return x[: self.nq], x[self.nq :]

    def predict(self, x, t: float, dt: float, jacobians: bool = False):
        k = int(round(dt / self.step))
        if k < 1 or abs(k * self.step - dt) > 1e-9 * max(1.0, dt):
            raise ValueError(f"dt: expected a whole multiple of the model step {self.step}, found {dt}")
        q, v = self.split(np.asarray(x, dtype=float))
        q1, v1, z, F, _Fu, G, H, _Hu, Hp = self.plant.predict(q, v, t, self.step, k, jacobians,
                                                              frozen=self.jacobian == "first_step")
        g = h = None
        if jacobians:
            dpdm = self._dparams_dmass(self.plant.params) if self._description.layout.has_target else np.zeros(G.shape[1])
            g, h = G @ dpdm, Hp @ dpdm
        return Prediction(np.concatenate([q1, v1]), z, F, g, H, h, G, Hp)

    def retract(self, x, dx):
        q, v = self.split(np.asarray(x, dtype=float))
        dx = np.asarray(dx, dtype=float)
        return np.concatenate([self.plant.integrate(q, dx[: self.nv]), v + dx[self.nv :]])

    def local(self, x1, x0):
        q1, v1 = self.split(np.asarray(x1, dtype=float))
        q0, v0 = self.split(np.asarray(x0, dtype=float))
        return np.concatenate([self.plant.difference(q0, q1), v1 - v0])

    def attitude(self, x) -> np.ndarray:
        return quat_from_pinocchio(np.asarray(x[3:7], dtype=float))

    def body_rate(self, x) -> np.ndarray:
        return np.asarray(x[self.nq + 3 : self.nq + 6], dtype=float)

    def chaser_position(self, x) -> np.ndarray:
        """Position of B's origin in N (m)."""
        return np.asarray(x[0:3], dtype=float)

    def chaser_velocity(self, x) -> np.ndarray:
        """Velocity of B's origin (the chaser's centre of mass), body components (m/s)."""
        return np.asarray(x[self.nq : self.nq + 3], dtype=float)

    def arm_angles(self, x) -> np.ndarray:
        """The arm's link-side joint angles (rad), what its encoders read."""
        return np.asarray(x[self._arm_q], dtype=float)
