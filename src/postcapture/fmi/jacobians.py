"""Where an FMU-backed process model gets its Jacobians: three strategies.

Every strategy gives ``F = d x_k+1 / d x_k`` and ``H = d z_k+1 / d x_k+1`` (tangent coordinates), and,
when the mapping names the inputs holding the plant's parameter vector, ``G = d x_k+1 / d p`` and
``Hp = d z_k+1 / d p``; the mass columns ``g`` and ``h`` follow from ``G`` and ``Hp`` along the hub-mass
direction when the mass is ``target.m`` plus an offset, or are taken for the mapping's mass variable.

``outputs``
    The FMU computes the exact step and measurement Jacobians itself (postcapture's exported FMUs:
    outputs ``F[i,j]``, ``G[i,j]``, ``H[i,j]``, ``Hp[i,j]`` after a step with ``jacobian_request = 1``,
    and ``jacobian_valid`` = 1). One call; exact.
``directional``
    Continuous partials from the FMU's directional derivatives at the end of the step (state derivatives
    and measurements with respect to the states and the parameter inputs: standard knowns), taken to
    tangent coordinates (``A_t = L^+ A L + (d/dt L^+) L``), then discretised over the step with the
    matrix exponential of ``[[A_t, B_t], [0, 0]] dt``: ``F`` and ``G`` are first-order accurate in ``dt``
    (the linearisation point is the predicted state), ``H`` and ``Hp`` are exact. A mass variable's
    column is a central difference on it.
``finite_differences``
    Central differences of whole steps over saved FMU states (``fmi2GetFMUstate`` /
    ``fmi2SetFMUstate``): ``2 (n + n_p) + 2`` steps. ``H`` follows from ``dz_k+1/dx_k = H F``.

Each strategy is a class with the capability flags ``exact`` and ``needs_fmu_state``; the registry
:data:`JACOBIAN_METHODS` maps names to them. ``compute`` returns ``(F, g, H, h, G, Hp)`` with ``None``
for what the mapping does not give.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from postcapture.core.errors import FMIError
from postcapture.fmi.slave import Buffer

__all__ = ["OutputJacobians", "DirectionalJacobians", "FiniteDifferenceJacobians", "JACOBIAN_METHODS"]


def _mass_columns(model, G, Hp):
    """``(g, h)`` from the parameter columns when the mass is ``target.m`` plus an offset, else ``(None, None)``."""
    if G is None or not model.mapping.mass_from_parameters:
        return None, None
    d = model.mass_direction()
    return G @ d, Hp @ d


class OutputJacobians:
    """Read the FMU's Jacobian outputs (see the module docstring)."""

    name = "outputs"
    exact = True
    needs_fmu_state = False
    uses_request = True

    def __init__(self, model):
        m = model
        jac = m.mapping.jacobians
        self._names = jac.expand(m.n, m.n_meas, m.n_params)
        self._keys = list(self._names)
        self._sizes = [len(self._names[k]) for k in self._keys]
        vrs = [m.vr[nm] for key in self._keys for nm in self._names[key]]
        self._valid = jac.valid is not None
        if self._valid:
            vrs.append(m.vr[jac.valid])
        self._buf = Buffer(vrs)
        self._shapes = {"F": (m.n, m.n), "H": (m.n_meas, m.n), "G": (m.n, m.n_params), "Hp": (m.n_meas, m.n_params),
                        "g": (m.n,), "h": (m.n_meas,)}

    def compute(self, model, x, t, dt, x1, z):
        """``(F, g, H, h, G, Hp)`` after the nominal step."""
        vals = model.slave.get_real(self._buf)
        if self._valid and not vals[-1] > 0.5:
            raise FMIError(f"{model.mapping.jacobians.valid} = {vals[-1]}: the Jacobian outputs do not describe the "
                           "last step (was jacobian_request honoured?)", fmu=model.label, function="fmi2GetReal")
        out, k = {}, 0
        for key, size in zip(self._keys, self._sizes, strict=True):
            out[key] = vals[k : k + size].reshape(self._shapes[key]).copy()
            k += size
        if not np.isfinite(out["F"]).all():
            raise FMIError("the Jacobian outputs are not finite (was jacobian_request honoured?)", fmu=model.label,
                           function="fmi2GetReal")
        G, Hp = out.get("G"), out.get("Hp")
        g, h = out.get("g"), out.get("h")
        if g is None:
            g, h = _mass_columns(model, G, Hp)
        return out["F"], g, out["H"], h, G, Hp


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
        self._known = Buffer([m.vr[n] for n in m.mapping.state] + [m.vr[n] for n in m.mapping.parameters or ()])
        self._xdot = Buffer([m.vr[n] for n in der])
        self._meas = Buffer([m.vr[n] for n in der] + [m.vr[n] for n in m.measurement_names])
        self._seed = np.zeros(self._known.n)
        self._col = np.zeros(self._unknown.n)

    def compute(self, model, x, t, dt, x1, z):
        """``(F, g, H, h, G, Hp)`` at the predicted state ``x1``."""
        nx, n, nm, n_p = model.nx, model.n, model.n_meas, model.n_params
        J = np.empty((self._unknown.n, self._known.n))
        for j in range(self._known.n):
            self._seed[:] = 0.0
            self._seed[j] = 1.0
            J[:, j] = model.slave.directional(self._unknown, self._known, self._seed, self._col)
        A, H_amb = J[:nx, :nx], J[nx:, :nx]
        xdot = model.slave.get_real(self._xdot).copy()
        kin = model.kinematics
        L, P, Pd = kin.basis(x1), kin.projector(x1), kin.projector_rate(x1, xdot)
        A_t = P @ A @ L + Pd @ L
        B = P @ J[:nx, nx:]  # (n, n_p): the parameter columns in tangent coordinates
        b = np.zeros((n, 0))
        h = None
        if model.mapping.mass is not None:  # a mass variable: a central difference on it
            m0 = model.mass
            dm = model.fd_mass_step * max(1.0, abs(m0))
            vals = []
            for sign in (1.0, -1.0):
                model.mass = m0 + sign * dm
                vals.append(model.slave.get_real(self._meas).copy())
            model.mass = m0
            d = (vals[0] - vals[1]) / (2 * dm)
            b, h = (P @ d[:nx])[:, None], d[nx:]
        k = n_p + b.shape[1]
        Mb = np.zeros((n + k, n + k))
        Mb[:n, :n] = A_t * dt
        Mb[:n, n:] = np.hstack([B, b]) * dt
        E = scipy.linalg.expm(Mb)
        F = E[:n, :n]
        G = E[:n, n : n + n_p] if n_p else None
        Hp = J[nx:, nx:] if n_p else None
        g = E[:n, n + n_p] if b.shape[1] else None
        if g is None:
            g, h = _mass_columns(model, G, Hp)
        return F, g, H_amb @ L, h, G, Hp


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

    def _columns(self, model, x, t, dt, perturb, steps):
        """Central differences of the step's ``(x_k+1 (-), z)`` over ``perturb(step) -> x`` for each step."""
        slave = model.slave
        res = []
        for step in steps:
            slave.set_state(self._before)
            res.append(model._raw_step(perturb(step), t, dt))
        return model.local(res[0][0], res[1][0]), res[0][1] - res[1][1]

    def compute(self, model, x, t, dt, x1, z):
        """``(F, g, H, h, G, Hp)`` around the nominal step from ``x``."""
        slave = model.slave
        self._after = slave.get_state(self._after)
        n, nm, eps, n_p = model.n, model.n_meas, model.fd_step, model.n_params
        F = np.zeros((n, n))
        M = np.zeros((nm, n))
        G = np.zeros((n, n_p)) if n_p else None
        Mp = np.zeros((nm, n_p))
        g = dz = None
        e = np.zeros(n)
        try:
            for j in range(n):
                def shifted(sign, j=j):
                    e[:] = 0.0
                    e[j] = sign * eps
                    return model.retract(x, e)
                dx, dzj = self._columns(model, x, t, dt, shifted, (1.0, -1.0))
                F[:, j], M[:, j] = dx / (2 * eps), dzj / (2 * eps)
            p0 = model.params if n_p else None
            try:
                for k in range(n_p):
                    dp = model.fd_mass_step * max(1.0, abs(p0[k]))
                    def moved(sign, k=k, dp=dp):
                        p = p0.copy()
                        p[k] += sign * dp
                        model.set_params(p)
                        return x
                    dx, dzk = self._columns(model, x, t, dt, moved, (1.0, -1.0))
                    G[:, k], Mp[:, k] = dx / (2 * dp), dzk / (2 * dp)
            finally:
                if n_p:
                    model.set_params(p0)
            if model.mapping.mass is not None:
                m0 = model.mass
                dm = model.fd_mass_step * max(1.0, abs(m0))
                try:
                    def heavier(sign):
                        model.mass = m0 + sign * dm
                        return x
                    dx, dzm = self._columns(model, x, t, dt, heavier, (1.0, -1.0))
                finally:
                    model.mass = m0
                g, dz = dx / (2 * dm), dzm / (2 * dm)
        finally:
            slave.set_state(self._after)
        # dz_k+1/dx_k = H F  =>  H = M F^-1;  dz_k+1/dp = H G + Hp;  dz_k+1/dm = H g + h
        H = np.linalg.solve(F.T, M.T).T
        Hp = Mp - H @ G if n_p else None
        h = dz - H @ g if g is not None else None
        if g is None:
            g, h = _mass_columns(model, G, Hp)
        return F, g, H, h, G, Hp

    def close(self, model):
        """Free the saved FMU states."""
        for h in (self._before, self._after):
            if h is not None and model.slave is not None:
                model.slave.free_state(h)
        self._before = self._after = None


JACOBIAN_METHODS = {c.name: c for c in (OutputJacobians, DirectionalJacobians, FiniteDifferenceJacobians)}
