"""Where an FMU-backed process model gets its Jacobians ``F``, ``g``, ``H``, ``h``: three strategies.

``outputs``
    The FMU computes the exact step and measurement Jacobians itself (postcapture's exported FMUs:
    outputs ``F[i,j]``, ``g[i]``, ``H[i,j]``, ``h[i]`` after a ``fmi2DoStep`` with
    ``jacobian_request = 1``). One call; exact.
``directional``
    Continuous partials from ``fmi2GetDirectionalDerivative`` at the end of the step (state
    derivatives and measurements with respect to the states), taken to tangent coordinates
    (``A_t = L^+ A L + (d/dt L^+) L``), the mass column by a central difference on the tunable mass
    parameter, then discretised over the step with the matrix exponential of the block matrix
    ``[[A_t, b_t], [0, 0]] dt``: ``F`` and ``g`` are first-order accurate in ``dt`` (the linearisation
    point is the predicted state), ``H`` and ``h`` are exact.
``finite_differences``
    Central differences of whole steps over saved FMU states (``fmi2GetFMUstate`` /
    ``fmi2SetFMUstate``): ``2 n + 2`` steps. ``H`` follows from ``dz_k+1/dx_k = H F``.

Each strategy is a class with the capability flags ``exact`` and ``needs_fmu_state``; the registry
:data:`JACOBIAN_METHODS` maps names to them.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from postcapture.core.errors import FMIError
from postcapture.fmi.slave import Buffer

__all__ = ["OutputJacobians", "DirectionalJacobians", "FiniteDifferenceJacobians", "JACOBIAN_METHODS"]


class OutputJacobians:
    """Read the FMU's Jacobian outputs (see the module docstring)."""

    name = "outputs"
    exact = True
    needs_fmu_state = False
    uses_request = True

    def __init__(self, model):
        m = model
        names = m.mapping.jacobians.expand(m.n, m.n_meas)
        vrs = [m.vr[n] for key in ("F", "g", "H", "h") for n in names[key]]
        self._buf = Buffer(vrs)
        self._n, self._m = m.n, m.n_meas

    def compute(self, model, x, t, dt, x1, z):
        """``(F, g, H, h)`` after the nominal step."""
        vals = model.slave.get_real(self._buf)
        n, m = self._n, self._m
        F = vals[: n * n].reshape(n, n).copy()
        g = vals[n * n : n * n + n].copy()
        H = vals[n * n + n : n * n + n + m * n].reshape(m, n).copy()
        h = vals[n * n + n + m * n :].copy()
        if not np.isfinite(F).all():
            raise FMIError(
                "the Jacobian outputs are not finite (was jacobian_request honoured?)",
                fmu=model.label,
                function="fmi2GetReal",
            )
        return F, g, H, h


class DirectionalJacobians:
    """Continuous partials from directional derivatives, discretised (see the module docstring)."""

    name = "directional"
    exact = False
    needs_fmu_state = False
    uses_request = False

    def __init__(self, model):
        m = model
        der = m.state_derivative_names()
        if der is None:
            raise FMIError(
                "directional derivatives need the state derivatives in ModelStructure/Derivatives",
                fmu=m.label,
                function="fmi2GetDirectionalDerivative",
            )
        self._unknown = Buffer([m.vr[n] for n in der] + [m.vr[n] for n in m.measurement_names])
        self._known = Buffer([m.vr[n] for n in m.mapping.state])
        self._xdot = Buffer([m.vr[n] for n in der])
        self._meas = Buffer([m.vr[n] for n in der] + [m.vr[n] for n in m.measurement_names])
        self._seed = np.zeros(m.nx)
        self._col = np.zeros(self._unknown.n)

    def compute(self, model, x, t, dt, x1, z):
        """``(F, g, H, h)`` at the predicted state ``x1``."""
        nx, n, nm = model.nx, model.n, model.n_meas
        J = np.empty((self._unknown.n, nx))
        for j in range(nx):
            self._seed[:] = 0.0
            self._seed[j] = 1.0
            J[:, j] = model.slave.directional(self._unknown, self._known, self._seed, self._col)
        A, H_amb = J[:nx], J[nx:]
        xdot = model.slave.get_real(self._xdot).copy()
        kin = model.kinematics
        L, P, Pd = kin.basis(x1), kin.projector(x1), kin.projector_rate(x1, xdot)
        A_t = P @ A @ L + Pd @ L
        H = H_amb @ L
        b = np.zeros(n)
        h = np.zeros(nm)
        if model.mapping.mass is not None:
            m0 = model.mass
            dm = model.fd_mass_step * max(1.0, abs(m0))
            vals = []
            for sign in (1.0, -1.0):
                model.mass = m0 + sign * dm
                vals.append(model.slave.get_real(self._meas).copy())
            model.mass = m0
            d = (vals[0] - vals[1]) / (2 * dm)
            b, h = P @ d[:nx], d[nx:]
        Mb = np.zeros((n + 1, n + 1))
        Mb[:n, :n] = A_t * dt
        Mb[:n, n] = b * dt
        E = scipy.linalg.expm(Mb)
        return E[:n, :n], E[:n, n], H, h


class FiniteDifferenceJacobians:
    """Central differences of whole steps over saved FMU states (see the module docstring)."""

    name = "finite_differences"
    exact = False
    needs_fmu_state = True
    uses_request = False

    def __init__(self, model):
        self._before = None
        self._after = None

    def save_before(self, model):
        """Save the FMU state before the nominal step."""
        self._before = model.slave.get_state(self._before)

    def compute(self, model, x, t, dt, x1, z):
        """``(F, g, H, h)`` around the nominal step from ``x``."""
        slave = model.slave
        self._after = slave.get_state(self._after)
        n, nm, eps = model.n, model.n_meas, model.fd_step
        F = np.zeros((n, n))
        M = np.zeros((nm, n))
        e = np.zeros(n)
        try:
            for j in range(n):
                res = []
                for sign in (1.0, -1.0):
                    e[:] = 0.0
                    e[j] = sign * eps
                    slave.set_state(self._before)
                    res.append(model._raw_step(model.retract(x, e), t, dt))
                F[:, j] = model.local(res[0][0], res[1][0]) / (2 * eps)
                M[:, j] = (res[0][1] - res[1][1]) / (2 * eps)
            g = np.zeros(n)
            dz = np.zeros(nm)
            if model.mapping.mass is not None:
                m0 = model.mass
                dm = model.fd_mass_step * max(1.0, abs(m0))
                res = []
                try:
                    for sign in (1.0, -1.0):
                        slave.set_state(self._before)
                        model.mass = m0 + sign * dm
                        res.append(model._raw_step(x, t, dt))
                finally:
                    model.mass = m0
                g = model.local(res[0][0], res[1][0]) / (2 * dm)
                dz = (res[0][1] - res[1][1]) / (2 * dm)
        finally:
            slave.set_state(self._after)
        # dz_k+1/dx_k = H F  =>  H = M F^-1;  dz_k+1/dm = H g + h
        H = np.linalg.solve(F.T, M.T).T
        return F, g, H, dz - H @ g

    def close(self, model):
        """Free the saved FMU states."""
        for h in (self._before, self._after):
            if h is not None and model.slave is not None:
                model.slave.free_state(h)
        self._before = self._after = None


JACOBIAN_METHODS = {c.name: c for c in (OutputJacobians, DirectionalJacobians, FiniteDifferenceJacobians)}
