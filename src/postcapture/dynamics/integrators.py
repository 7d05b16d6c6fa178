"""Fixed-step Runge-Kutta integrators on the configuration Lie group, with exact step Jacobians.

One scheme covers explicit RK and diagonally implicit RK (DIRK): Runge-Kutta-Munthe-Kaas in the chart
``q = q_k (+) xi`` centred on the step's start. Stage ``i`` solves

    xi_i = h sum_j a_ij Kxi_j,   V_i = v_k + h sum_j a_ij Kv_j,
    Kxi_j = dexpinv(xi_j) V_j,   Kv_j = f(q_k (+) xi_j, V_j, t_k + c_j h)

(``dexpinv`` on the free flyer's 6 coordinates, the identity on joint angles). Explicit stages
(a_ii = 0) are evaluated; implicit ones are solved by a simplified Newton iteration whose matrix,
reduced to nv x nv, is ``I - h g ddq_dv - (h g)^2 ddq_dq`` at the step's start.

* ``rk4``: classical RK4, order 4 (the Munthe-Kaas correction keeps order 4 on SE(3)); explicit, so
  its step is limited by the stiffest mode (about 2.8 / omega_max).
* ``sdirk3``: Alexander's 3-stage SDIRK, order 3, L-stable and stiffly accurate; its step is not
  limited by the stiff arm-joint modes, which it damps.
* ``sdirk2``: Alexander's 2-stage SDIRK, order 2, L-stable.

Step Jacobians: differentiating every stage equation (implicit function theorem) gives the exact
derivative of the step actually taken with respect to ``(q_k, v_k)`` (tangent coordinates), a constant
input offset ``u`` over the step, and the target mass, using Pinocchio's analytic ABA derivatives and
``dIntegrate`` at each converged stage.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.linalg.lapack import dgetrf as _getrf, dgetrs as _getrs

from postcapture.core.errors import SimulationError
from postcapture.dynamics.liegroup import dexpinv, dexpinv_apply, dexpinv_dxi
from postcapture.dynamics.system import System

__all__ = ["Tableau", "TABLEAUX", "StepJacobian", "LieRungeKutta", "make_integrator"]

_G3 = 0.43586652150845899941601945  # root of x^3 - 3x^2 + 3/2 x - 1/6 in (1/6, 1/2)
_G2 = 1.0 - 1.0 / np.sqrt(2.0)


@dataclass(frozen=True)
class Tableau:
    """A Butcher tableau with a lower-triangular ``A``."""

    name: str
    A: np.ndarray
    b: np.ndarray
    c: np.ndarray
    order: int
    l_stable: bool

    @property
    def stages(self) -> int:
        """Number of stages."""
        return len(self.b)

    @property
    def stiffly_accurate(self) -> bool:
        """True when the last stage is the step's result (``b`` is the last row of ``A``)."""
        return bool(np.array_equal(self.A[-1], self.b))


TABLEAUX = {
    "rk4": Tableau(
        "rk4",
        np.array([[0, 0, 0, 0], [0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 1.0, 0]]),
        np.array([1 / 6, 1 / 3, 1 / 3, 1 / 6]),
        np.array([0, 0.5, 0.5, 1.0]),
        4,
        False,
    ),
    "sdirk2": Tableau(
        "sdirk2",
        np.array([[_G2, 0.0], [1 - _G2, _G2]]),
        np.array([1 - _G2, _G2]),
        np.array([_G2, 1.0]),
        2,
        True,
    ),
    "sdirk3": Tableau(
        "sdirk3",
        np.array(
            [
                [_G3, 0.0, 0.0],
                [(1 - _G3) / 2, _G3, 0.0],
                [-(6 * _G3**2 - 16 * _G3 + 1) / 4, (6 * _G3**2 - 20 * _G3 + 5) / 4, _G3],
            ]
        ),
        np.array([-(6 * _G3**2 - 16 * _G3 + 1) / 4, (6 * _G3**2 - 20 * _G3 + 5) / 4, _G3]),
        np.array([_G3, (1 + _G3) / 2, 1.0]),
        3,
        True,
    ),
}


@dataclass
class StepJacobian:
    """A step and its exact Jacobian in tangent coordinates.

    ``Fx`` (2nv x 2nv) maps ``(dq_k, dv_k)`` to ``(dq_k+1, dv_k+1)``; ``Fu`` (2nv x n_u) a constant input
    offset over the step; ``Fp`` (2nv x n_p) the system's parameter vector
    (:mod:`postcapture.dynamics.parameters`), None when not requested; ``Fm`` (2nv,) the total target
    mass (None without a target).
    """

    q: np.ndarray
    v: np.ndarray
    Fx: np.ndarray
    Fu: np.ndarray
    Fp: np.ndarray | None
    Fm: np.ndarray | None


class LieRungeKutta:
    """A fixed-step Lie-group Runge-Kutta integrator bound to a :class:`System`.

    Parameters
    ----------
    system : System
    method : str or Tableau
        ``"sdirk3"`` (default), ``"sdirk2"`` or ``"rk4"``.
    newton_tol, newton_atol : float
        Relative and absolute Newton tolerances (SI units). A stage is accepted, after at least two
        iterations, when the RMS of its last correction, each coordinate scaled by
        ``newton_atol + newton_tol |y_i|`` (``y`` the chart coordinates and velocities at the predictor),
        is below 1. The converged stages then agree with a tight solve to about 1e-11.
    max_newton : int
        Iterations before the Newton matrix is refreshed at the stage; a second failure raises.
    reuse_jacobian : int
        Steps a Newton matrix is kept (simplified Newton); 1 refreshes it every step.
    """

    def __init__(self, system: System, method: str | Tableau = "sdirk3", newton_tol: float = 1e-9, newton_atol: float = 1e-11, max_newton: int = 12, reuse_jacobian: int = 6):
        self.system = system
        self.tableau = TABLEAUX[method] if isinstance(method, str) else method
        self._stiffly_accurate = self.tableau.stiffly_accurate
        self._A_rows = [[float(a) for a in row] for row in self.tableau.A]
        self._c = [float(x) for x in self.tableau.c]
        self._s = self.tableau.stages
        self.newton_tol = newton_tol
        self.newton_atol = newton_atol
        self.max_newton = max_newton
        self.n_ff = system.n_root_v  # 6 with a free-flyer root, 0 on a fixed base
        self.reuse_jacobian = reuse_jacobian
        self.stats = {"steps": 0, "newton_iterations": 0, "jacobians": 0}
        self._lu = None
        self._lu_age = 0
        self._max_it = 0
        self._fsal = None

    # ------------------------------------------------------------------ kinematics in the chart
    def _kxi(self, xi: np.ndarray, V: np.ndarray) -> np.ndarray:
        if not self.n_ff:
            return V
        out = V.copy()
        out[:6] = dexpinv_apply(xi[:6], V[:6])
        return out

    # ------------------------------------------------------------------ Newton matrix
    def _newton_matrix(self, q, v, u, hg):
        _, dq, dv, _ = self.system.derivatives_u(q, v, u)
        S = np.eye(self.system.nv) - hg * dv - hg * hg * dq
        lu, piv, info = _getrf(S)
        if info != 0:
            raise SimulationError(f"{self.tableau.name}: singular Newton matrix (LAPACK info {info})")
        self._lu = (lu, piv, dq, hg)
        self._lu_age = 0
        self.stats["jacobians"] += 1

    def _solve_stage(self, q, u_i, tau_i, xi_bar, V_bar, hg, xi, V, t_start):
        sysm = self.system
        model = sysm.model
        integrate, accel, getrs = pin.integrate, sysm.acceleration_tau, _getrs
        ff = self.n_ff
        # per-component weights 1 / (atol + rtol |y_i|): a small stiff coordinate converges as tightly as a
        # large one (a single global norm let slow stiff arm-joint rates stop early at ~1e-4 relative)
        w_xi = 1.0 / (self.newton_atol + self.newton_tol * np.abs(xi))
        w_V = 1.0 / (self.newton_atol + self.newton_tol * np.abs(V))
        inv_n = 1.0 / (2 * xi.size)
        for attempt in range(2):
            lu, piv, dq, _ = self._lu
            for it in range(self.max_newton):
                Kv = accel(integrate(model, q, xi), V, tau_i)
                if ff:
                    kx = V.copy()
                    kx[:6] = dexpinv_apply(xi[:6], V[:6])
                    r_xi = xi - xi_bar - hg * kx
                else:
                    r_xi = xi - xi_bar - hg * V
                dV = getrs(lu, piv, V_bar - V + hg * (Kv - dq @ r_xi))[0]
                dxi = hg * dV - r_xi
                xi = xi + dxi
                V = V + dV
                # weighted RMS norm of the correction (squared)
                a, b = dV * w_V, dxi * w_xi
                err = float(a @ a + b @ b) * inv_n
                if not err < math.inf:
                    break
                # Accept once a correction (after the first) is below 1 in RMS, each coordinate on its own
                # scale. Extrapolating with the global contraction rate (Hairer & Wanner IV.8) saved an
                # iteration but let slowly contracting stiff arm-joint rates stop 1e-8 off, which truth
                # and filter copies then disagree by; this keeps them within 1e-10.
                if it and err <= 1.0:
                    self.stats["newton_iterations"] += it + 1
                    if it + 1 > self._max_it:
                        self._max_it = it + 1
                    return xi, V
            self.stats["newton_iterations"] += self.max_newton
            if attempt == 0:  # refresh the Newton matrix at the current stage guess and retry
                self._newton_matrix(integrate(model, q, xi), V, u_i, hg)
        raise SimulationError(
            f"{self.tableau.name}: Newton did not converge at t = {t_start:.6g} s (step too large or state non-finite)"
        )

    # ------------------------------------------------------------------ one step
    def _stages(self, q, v, t, h, u_extra, refresh):
        """Solve every stage; returns the stages ``(xi, V, t_i, u_i)``, their slopes and the step's end."""
        sysm = self.system
        A, c = self._A_rows, self._c
        Kxi: list = []
        Kv: list = []
        Z = []
        fsal = self._fsal if (self._fsal is not None and self._fsal[0] is q) else None
        self._max_it = 0
        for i in range(self._s):
            row = A[i]
            if i:
                xi_bar = (h * row[0]) * Kxi[0]
                V_bar = v + (h * row[0]) * Kv[0]
                for j in range(1, i):
                    if row[j] != 0.0:
                        xi_bar = xi_bar + (h * row[j]) * Kxi[j]
                        V_bar = V_bar + (h * row[j]) * Kv[j]
            else:
                xi_bar = np.zeros(sysm.nv)
                V_bar = v
            t_i = t + c[i] * h
            u_i = sysm.input_vector(t_i, u_extra, left=c[i] == 1.0)
            tau_i = sysm.input_torque(u_i)
            g = row[i]
            if g == 0.0:
                xi, V = xi_bar, V_bar
                Kxi.append(self._kxi(xi, V))
                Kv.append(sysm.acceleration_tau(pin.integrate(sysm.model, q, xi), V, tau_i))
            else:
                hg = h * g
                if i == 0 and (refresh or self._lu is None or self._lu[3] != hg or self._lu_age >= self.reuse_jacobian):
                    self._newton_matrix(q, v, sysm.input_vector(t, u_extra), hg)
                if fsal is not None and len(fsal[2]) > i:
                    # the same stage of the previous step, shifted by how the step's start moved: the stiff,
                    # quasi-static coordinates change smoothly from step to step, unlike along the stages
                    V0 = fsal[2][i] + (v - fsal[3])
                    xi0 = xi_bar + hg * V0
                elif i:  # continue with the previous stage's slopes
                    xi0, V0 = xi_bar + hg * Kxi[i - 1], V_bar + hg * Kv[i - 1]
                elif fsal is not None:  # the previous step's last slope
                    xi0, V0 = hg * v, v + hg * fsal[1]
                else:
                    xi0, V0 = hg * v, v
                xi, V = self._solve_stage(q, u_i, tau_i, xi_bar, V_bar, hg, xi0, V0, t)
                inv = 1.0 / hg
                Kxi.append((xi - xi_bar) * inv)
                Kv.append((V - V_bar) * inv)
            Z.append((xi, V, t_i, u_i))
        if self._stiffly_accurate:
            xi_end, v_end = Z[-1][0], Z[-1][1]
        else:
            b = self.tableau.b
            xi_end = h * sum(b[i] * Kxi[i] for i in range(self._s))
            v_end = v + h * sum(b[i] * Kv[i] for i in range(self._s))
        self._last_Z, self._last_v = Z, v
        if self._lu is not None:
            self._lu_age += 1
            if self._max_it > 4:  # slow convergence: refresh at the next step
                self._lu_age = self.reuse_jacobian
        return Z, Kxi, Kv, xi_end, v_end

    def _finish(self, q, xi_end, v_end, Kv, t):
        self.stats["steps"] += 1
        q1 = pin.integrate(self.system.model, q, xi_end)
        if not (np.isfinite(q1).all() and np.isfinite(v_end).all()):
            raise SimulationError(f"{self.tableau.name}: non-finite state after the step at t = {t:.6g} s")
        self._fsal = (q1, Kv[-1], [Z_i[1] for Z_i in self._last_Z], self._last_v) if self._stiffly_accurate else None
        return q1

    def step(self, q: np.ndarray, v: np.ndarray, t: float, h: float, u_extra=None, refresh: bool = False):
        """Advance ``(q, v)`` from ``t`` to ``t + h``.

        Parameters
        ----------
        q, v : ndarray
            Configuration (nq,) and velocity (nv,).
        t, h : float
            Start time and step (s).
        u_extra : ndarray, shape (n_u,), optional
            Constant input added to the scenario's schedule over the step.
        refresh : bool
            Force a new Newton matrix at the step's start (implicit methods). By default it is reused
            for ``reuse_jacobian`` steps, and refreshed early when Newton slows down.

        Returns
        -------
        q1, v1 : ndarray
        """
        _, _, Kv, xi_end, v_end = self._stages(q, v, t, h, u_extra, refresh)
        return self._finish(q, xi_end, v_end, Kv, t), v_end

    def step_quadrature(self, q, v, t, h, integrand, u_extra=None, refresh: bool = False):
        """Take one step and integrate ``integrand(q, v, u)`` over it with the method's own quadrature.

        Returns ``(q1, v1, h * sum_i b_i integrand(stage_i))``: for example the work done by the inputs,
        accurate to the integrator's order.
        """
        Z, _, Kv, xi_end, v_end = self._stages(q, v, t, h, u_extra, refresh)
        model = self.system.model
        total = 0.0
        for b_i, (xi, V, _, u_i) in zip(self.tableau.b, Z):
            total = total + b_i * integrand(pin.integrate(model, q, xi), V, u_i)
        return self._finish(q, xi_end, v_end, Kv, t), v_end, h * total

    # ------------------------------------------------------------------ step Jacobian
    def step_jacobian(self, q, v, t: float, h: float, u_extra=None, wrt_params: bool = True) -> StepJacobian:
        """Take one step and return it with its exact Jacobian (see :class:`StepJacobian`)."""
        sysm = self.system
        model = sysm.model
        tab = self.tableau
        nv, nu = sysm.nv, sysm.n_u
        n_par = len(sysm.parameter_names) if wrt_params else 0
        n_p = 2 * nv + nu + n_par
        Z, Kxi, Kv, xi_end, v_end = self._stages(q, v, t, h, u_extra, refresh=False)
        q1 = self._finish(q, xi_end, v_end, Kv, t)
        I2 = np.eye(2 * nv)
        dK = []  # (2nv, n_p) each
        base = np.zeros((2 * nv, n_p))
        base[nv:, nv : 2 * nv] = np.eye(nv)  # V_bar contains v_k
        for i, (xi, V, t_i, u_i) in enumerate(Z):
            dZbar = base.copy()
            for j in range(i):
                if tab.A[i, j] != 0.0:
                    dZbar += h * tab.A[i, j] * dK[j]
            qi = pin.integrate(model, q, xi)
            ddq, Aq, Av, Minv = sysm.derivatives_u(qi, V, u_i)
            Jr = pin.dIntegrate(model, q, xi, pin.ArgumentPosition.ARG1)
            J0 = pin.dIntegrate(model, q, xi, pin.ArgumentPosition.ARG0)
            dKdZ = np.zeros((2 * nv, 2 * nv))
            dKdZ[:nv, nv:] = np.eye(nv)
            if self.n_ff:
                dKdZ[:6, :6] = dexpinv_dxi(xi[:6], V[:6])
                dKdZ[:6, nv : nv + 6] = dexpinv(xi[:6])
            dKdZ[nv:, :nv] = Aq @ Jr
            dKdZ[nv:, nv:] = Av
            dKdp = np.zeros((2 * nv, n_p))
            dKdp[nv:, :nv] = Aq @ J0
            dKdp[nv:, 2 * nv : 2 * nv + nu] = Minv @ sysm.B
            if n_par:
                dKdp[nv:, 2 * nv + nu :] = sysm.ddq_dparams(qi, V, ddq, Minv)
            g = tab.A[i, i]
            if g == 0.0:
                dZ = dZbar
            else:
                hg = h * g
                dZ = np.linalg.solve(I2 - hg * dKdZ, dZbar + hg * dKdp)
            dK.append(dKdZ @ dZ + dKdp)
        if self._stiffly_accurate:
            d_end = dZ
        else:
            d_end = base + h * sum(tab.b[i] * dK[i] for i in range(tab.stages))
        J0e = pin.dIntegrate(model, q, xi_end, pin.ArgumentPosition.ARG0)
        Jre = pin.dIntegrate(model, q, xi_end, pin.ArgumentPosition.ARG1)
        dq1 = Jre @ d_end[:nv]
        dq1[:, :nv] += J0e
        F = np.vstack([dq1, d_end[nv:]])
        Fp = F[:, 2 * nv + nu :] if n_par else None
        return StepJacobian(
            q=q1,
            v=v_end,
            Fx=F[:, : 2 * nv],
            Fu=F[:, 2 * nv : 2 * nv + nu],
            Fp=Fp,
            Fm=Fp @ sysm.dparams_dmass() if (n_par and sysm.layout.has_target) else None,
        )


def make_integrator(system: System, method: str = "sdirk3", **kwargs) -> LieRungeKutta:
    """Build an integrator by name (``"sdirk3"``, ``"sdirk2"``, ``"rk4"``)."""
    if method not in TABLEAUX:
        raise ValueError(f"integrator: expected one of {sorted(TABLEAUX)}, found {method!r}")
    return LieRungeKutta(system, method, **kwargs)
