"""The Python Lie-group Runge-Kutta integrators: the test oracle of the compiled core.

They were the production path before the compiled core (``postcapture/dynamics/csrc``); they stay here,
outside the package, as an independent implementation over Pinocchio (``pinocchio.integrate``, and the
plant's equations of ``tests/pinocchio_reference.py``: ``aba``, ``computeABADerivatives``) that the core's
steps and step Jacobians are held to.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.linalg.lapack import dgetrf as _getrf, dgetrs as _getrs

import pinocchio_reference as ref
from postcapture.core.errors import SimulationError
from postcapture.dynamics.integrators import TABLEAUX, Tableau
from postcapture.dynamics.liegroup import ad
from postcapture.dynamics.system import System


def dexpinv(xi: np.ndarray) -> np.ndarray:
    """Matrix ``G(xi) = I + ad_xi / 2 + ad_xi^2 / 12`` with ``d xi/dt = G(xi) V`` (6x6)."""
    A = ad(xi)
    return np.eye(6) + 0.5 * A + (A @ A) / 12.0


def dexpinv_apply(xi: np.ndarray, V: np.ndarray) -> np.ndarray:
    """``G(xi) @ V`` with scalar arithmetic (the integrator's innermost loop)."""
    r0, r1, r2, p0, p1, p2 = xi.tolist()
    v0, v1, v2, w0, w1, w2 = V.tolist()
    # a = [xi, V] = (phi x v + rho x w, phi x w)
    a0 = p1 * v2 - p2 * v1 + r1 * w2 - r2 * w1
    a1 = p2 * v0 - p0 * v2 + r2 * w0 - r0 * w2
    a2 = p0 * v1 - p1 * v0 + r0 * w1 - r1 * w0
    a3 = p1 * w2 - p2 * w1
    a4 = p2 * w0 - p0 * w2
    a5 = p0 * w1 - p1 * w0
    # b = [xi, a]
    b0 = p1 * a2 - p2 * a1 + r1 * a5 - r2 * a4
    b1 = p2 * a0 - p0 * a2 + r2 * a3 - r0 * a5
    b2 = p0 * a1 - p1 * a0 + r0 * a4 - r1 * a3
    b3 = p1 * a5 - p2 * a4
    b4 = p2 * a3 - p0 * a5
    b5 = p0 * a4 - p1 * a3
    c = 1.0 / 12.0
    return np.array(
        [v0 + 0.5 * a0 + c * b0, v1 + 0.5 * a1 + c * b1, v2 + 0.5 * a2 + c * b2,
         w0 + 0.5 * a3 + c * b3, w1 + 0.5 * a4 + c * b4, w2 + 0.5 * a5 + c * b5]
    )


def dexpinv_dxi(xi: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Derivative of ``G(xi) V`` with respect to ``xi`` at fixed ``V`` (6x6).

    With ``d/dxi [xi, W] = -ad_W``: ``-ad_V / 2 - (ad_{[xi, V]} + ad_xi ad_V) / 12``.
    """
    A = ad(xi)
    adV = ad(V)
    return -0.5 * adV - (ad(A @ V) + A @ adV) / 12.0


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
        _, dq, dv, _ = ref.derivatives_u(self.system, q, v, u, self._springs)
        S = np.eye(self.system.nv) - hg * dv - hg * hg * dq
        lu, piv, info = _getrf(S)
        if info != 0:
            raise SimulationError(f"{self.tableau.name}: singular Newton matrix (LAPACK info {info})")
        self._lu = (lu, piv, dq, hg)
        self._lu_age = 0
        self.stats["jacobians"] += 1

    def _solve_stage(self, q, u_i, xi_bar, V_bar, hg, xi, V, t_start):
        sysm = self.system
        model = ref.pin_data(sysm)[0]
        integrate, accel, getrs, sp = pin.integrate, ref.acceleration_u, _getrs, self._springs
        ff = self.n_ff
        # per-component weights 1 / (atol + rtol |y_i|): a small stiff coordinate converges as tightly as a
        # large one (a single global norm let slow stiff arm-joint rates stop early at ~1e-4 relative)
        w_xi = 1.0 / (self.newton_atol + self.newton_tol * np.abs(xi))
        w_V = 1.0 / (self.newton_atol + self.newton_tol * np.abs(V))
        inv_n = 1.0 / (2 * xi.size)
        for attempt in range(2):
            lu, piv, dq, _ = self._lu
            for it in range(self.max_newton):
                Kv = accel(sysm, integrate(model, q, xi), V, u_i, sp)
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
    @staticmethod
    def _predictor(i, v, hg, xi_bar, V_bar, Kxi, Kv, fsal):
        """Newton's starting point for implicit stage ``i``."""
        if fsal is not None and len(fsal[2]) > i:
            # the same stage of the previous step, shifted by how the step's start moved: the stiff,
            # quasi-static coordinates change smoothly from step to step, unlike along the stages
            V0 = fsal[2][i] + (v - fsal[3])
            return xi_bar + hg * V0, V0
        if i:  # continue with the previous stage's slopes
            return xi_bar + hg * Kxi[i - 1], V_bar + hg * Kv[i - 1]
        if fsal is not None:  # the previous step's last slope
            return hg * v, v + hg * fsal[1]
        return hg * v, v

    def _stages(self, q, v, t, h, u_extra, refresh):
        """Solve every stage; returns the stages ``(xi, V, t_i, u_i)``, their slopes and the step's end."""
        sysm = self.system
        self._springs = sp = ref.springs(sysm)  # the springs at the current parameters, for the whole step
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
            g = row[i]
            if g == 0.0:
                xi, V = xi_bar, V_bar
                Kxi.append(self._kxi(xi, V))
                Kv.append(ref.acceleration_u(sysm, pin.integrate(ref.pin_data(sysm)[0], q, xi), V, u_i, sp))
            else:
                hg = h * g
                if i == 0 and (refresh or self._lu is None or self._lu[3] != hg or self._lu_age >= self.reuse_jacobian):
                    self._newton_matrix(q, v, sysm.input_vector(t, u_extra), hg)
                xi0, V0 = self._predictor(i, v, hg, xi_bar, V_bar, Kxi, Kv, fsal)
                xi, V = self._solve_stage(q, u_i, xi_bar, V_bar, hg, xi0, V0, t)
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
        q1 = pin.integrate(ref.pin_data(self.system)[0], q, xi_end)
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
        model = ref.pin_data(self.system)[0]
        total = 0.0
        for b_i, (xi, V, _, u_i) in zip(self.tableau.b, Z):
            total = total + b_i * integrand(pin.integrate(model, q, xi), V, u_i)
        return self._finish(q, xi_end, v_end, Kv, t), v_end, h * total

    # ------------------------------------------------------------------ step Jacobian
    def step_jacobian(self, q, v, t: float, h: float, u_extra=None, wrt_params: bool = True) -> StepJacobian:
        """Take one step and return it with its exact Jacobian (see :class:`StepJacobian`)."""
        sysm = self.system
        model = ref.pin_data(sysm)[0]
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
            ddq, Aq, Av, Minv = ref.derivatives_u(sysm, qi, V, u_i, self._springs)
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
                dKdp[nv:, 2 * nv + nu :] = ref.ddq_dparams(sysm, qi, V, ddq, Minv, self._springs)
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
