"""The compiled plant core behind a Python object: a shared constant model and one instance's own data.

:class:`CompiledPlant` pairs an :class:`~postcapture.dynamics.engine.EngineModel` (the constant
``pc_model_t``, packed from a :class:`~postcapture.dynamics.system.System` and validated by the core)
with its own ``pc_data_t``: the parameter vector, input offset, Newton settings, warm start, statistics
and scratch arena. :meth:`CompiledPlant.copy` makes another instance over the same model (a filter's own
plant): the copies share nothing mutable. Every call goes through the typed, status-checked boundary of
:mod:`postcapture.dynamics.engine`; a failure raises an :class:`~postcapture.dynamics.engine.EngineError`
subclass (a :class:`~postcapture.core.errors.SimulationError`) with the core's message.
"""

from __future__ import annotations

import ctypes

import numpy as np

from postcapture.core.errors import DimensionError
from postcapture.dynamics.engine import EngineModel

__all__ = ["CompiledPlant", "MECH_FIELDS"]

MECH_FIELDS = ("com_N", "momentum_N", "angular_momentum_N", "energy_kinetic", "energy_elastic")


def _vec(x, n: int, name: str) -> np.ndarray:
    a = np.ascontiguousarray(x, dtype=np.float64)
    if a.shape != (n,):
        raise DimensionError(f"{name}: expected shape ({n},), found {a.shape}")
    return a


class CompiledPlant:
    """One instance of the plant in the compiled core.

    Parameters
    ----------
    system : System
        The model to pack (its parameter vector becomes this instance's starting parameters).
    integrator : str or Tableau
        ``"sdirk3"`` (default), ``"sdirk4"``, ``"sdirk2"``, ``"rk4"`` or any lower-triangular tableau.
    model : EngineModel, optional
        Run over this constant model instead of packing ``system`` (what :meth:`copy` does).
    """

    def __init__(self, system=None, integrator="sdirk3", *, model: EngineModel | None = None):
        if model is None:
            from postcapture.dynamics.integrators import TABLEAUX
            from postcapture.dynamics.packing import pack

            tab = TABLEAUX[integrator] if isinstance(integrator, str) else integrator
            packed = pack(system)
            model = EngineModel(packed.ints, packed.doubles, tab, packed.params.names)
        self.model = model
        self._eng = model.engine
        self.param_names = model.param_names
        self.nq, self.nv, self.nu, self.np, self.nz = model.nq, model.nv, model.nu, model.np, model.nz
        self.npanels, self.nj, self.nt = model.npanels, model.nj, model.nt
        self.tableau = model.tableau
        handle = self._eng.data_create(model.handle)
        if not handle:
            raise MemoryError("the compiled core could not allocate an instance's data")
        self._d = handle
        self._m = model.handle

    def __del__(self):
        d, eng = getattr(self, "_d", None), getattr(self, "_eng", None)
        if d and eng is not None:
            eng.data_destroy(d)
            self._d = None

    def __reduce__(self):
        raise TypeError("a CompiledPlant is an instance in this process's compiled core and cannot be pickled: "
                        "send its System (or its model, an EngineModel) and build the instance where it runs")

    def copy(self) -> "CompiledPlant":
        """Another instance over the same constant model, with this one's parameters, input offset and
        Newton settings (not its warm start or statistics)."""
        other = CompiledPlant(model=self.model)
        self._eng.data_copy(self._m, other._d, self._d)
        return other

    # ------------------------------------------------------------------ settings
    def set_tableau(self, tableau) -> None:
        """Use another Butcher tableau from now on: a new constant model, this instance's settings kept."""
        from postcapture.dynamics.integrators import TABLEAUX

        tab = TABLEAUX[tableau] if isinstance(tableau, str) else tableau
        packed_from = self.model
        other = CompiledPlant(model=_with_tableau(packed_from, tab))
        self._eng.data_copy(other._m, other._d, self._d)
        self._eng.data_destroy(self._d)
        self.model, self._m, self._d, self.tableau = other.model, other._m, other._d, tab
        other._d = None

    def set_newton(self, rtol: float, atol: float, max_iter: int = 12) -> None:
        """Newton acceptance of the implicit stages (see ``csrc/pc_integrator.c``)."""
        self._eng.set_newton(self._d, float(rtol), float(atol), int(max_iter))

    @property
    def params(self) -> np.ndarray:
        """The current parameter vector (see :class:`postcapture.dynamics.packing.ParameterLayout`)."""
        p = np.zeros(self.np)
        self._eng.get_params(self._m, self._d, p)
        return p

    def set_params(self, p) -> None:
        """Set the whole parameter vector; refused (EngineArgumentError, a DomainError) when not physical."""
        self._eng.set_params(self._m, self._d, _vec(p, self.np, "p"))

    def set_input_offset(self, u_extra=None) -> None:
        """A constant input added to the excitation in every following call (None: zero)."""
        self._eng.set_input_offset(self._m, self._d, None if u_extra is None else _vec(u_extra, self.nu, "u_extra"))

    def set_orbit(self, mean_motion: float) -> None:
        """A circular orbit of this mean motion (rad/s; 0: free space): the gravity gradient acts on every body
        in every following call (``csrc/pc_gravity.c``; N is the orbit's local-vertical local-horizontal frame
        at t = 0, x the zenith, y along the track, z the orbit normal)."""
        self._eng.set_orbit(self._m, self._d, float(mean_motion))

    def stats(self) -> dict:
        """Steps, Newton iterations and factorizations since the last reset; the arena's high-water mark."""
        out = np.zeros(4, dtype=np.int64)
        self._eng.stats(self._d, out)
        return {"steps": int(out[0]), "newton_iterations": int(out[1]), "factorizations": int(out[2]),
                "arena_peak": int(out[3])}

    def reset_warm_start(self) -> None:
        """Forget the previous step's stages (the next step starts Newton cold) and the counters."""
        self._eng.reset_stats(self._d)

    # ------------------------------------------------------------------ dynamics
    def inputs(self, t: float, left: bool = False) -> np.ndarray:
        """The excitation (plus the input offset) at ``t``, shape (nu,)."""
        u = np.zeros(self.nu)
        self._eng.inputs(self._m, self._d, float(t), int(left), u)
        return u

    def aba(self, q, v, tau) -> np.ndarray:
        """``M^-1 (tau - b(q, v))`` (no springs)."""
        out = np.zeros(self.nv)
        self._eng.aba(self._m, self._d, _vec(q, self.nq, "q"), _vec(v, self.nv, "v"), _vec(tau, self.nv, "tau"), out)
        return out

    def rnea(self, q, v, a) -> np.ndarray:
        """Inverse dynamics ``M a + b(q, v)`` (no springs)."""
        out = np.zeros(self.nv)
        self._eng.rnea(self._m, self._d, _vec(q, self.nq, "q"), _vec(v, self.nv, "v"), _vec(a, self.nv, "a"), out)
        return out

    def rnea_derivatives(self, q, v, a):
        """``d ID / dq`` (tangent) and ``d ID / dv`` of the inverse dynamics (no springs), each (nv, nv)."""
        dq, dv = np.zeros((self.nv, self.nv)), np.zeros((self.nv, self.nv))
        self._eng.rnea_derivatives(self._m, self._d, _vec(q, self.nq, "q"), _vec(v, self.nv, "v"),
                                   _vec(a, self.nv, "a"), dq, dv)
        return dq, dv

    def acceleration(self, q, v, u) -> np.ndarray:
        """``ddq`` with springs, dampers and the input vector ``u`` (nu,)."""
        out = np.zeros(self.nv)
        self._eng.accel(self._m, self._d, _vec(q, self.nq, "q"), _vec(v, self.nv, "v"), _vec(u, self.nu, "u"), out)
        return out

    def derivatives(self, q, v, u):
        """``ddq`` and its exact partials ``Aq`` (tangent), ``Av``, ``Au``, ``Ap``."""
        nv = self.nv
        ddq, Aq, Av = np.zeros(nv), np.zeros((nv, nv)), np.zeros((nv, nv))
        Au, Ap = np.zeros((nv, self.nu)), np.zeros((nv, self.np))
        self._eng.derivatives(self._m, self._d, _vec(q, self.nq, "q"), _vec(v, nv, "v"), _vec(u, self.nu, "u"), ddq,
                              Aq, Av, Au, Ap)
        return ddq, Aq, Av, Au, Ap

    def mass_matrix(self, q) -> np.ndarray:
        """The joint-space mass matrix ``M(q)`` (composite-rigid-body algorithm)."""
        M = np.zeros((self.nv, self.nv))
        self._eng.mass_matrix(self._m, self._d, _vec(q, self.nq, "q"), M)
        return M

    def center_of_mass(self, q) -> np.ndarray:
        """The whole tree's centre of mass in N at ``q`` (m)."""
        com = np.zeros(3)
        self._eng.center_of_mass(self._m, self._d, _vec(q, self.nq, "q"), com)
        return com

    def integrate(self, q, dq) -> np.ndarray:
        """``q (+) dq`` on the configuration group."""
        out = np.zeros(self.nq)
        self._eng.integrate(self._m, _vec(q, self.nq, "q"), _vec(dq, self.nv, "dq"), out)
        return out

    def difference(self, q0, q1) -> np.ndarray:
        """``q1 (-) q0``: the tangent vector ``dq`` with ``q0 (+) dq = q1``."""
        out = np.zeros(self.nv)
        self._eng.difference(self._m, _vec(q0, self.nq, "q0"), _vec(q1, self.nq, "q1"), out)
        return out

    def panel_outputs(self, q) -> np.ndarray:
        """Per panel: tip deflection in its root frame (3) and root torsion, shape (npanels, 4)."""
        out = np.zeros((self.npanels, 4))
        self._eng.panel_outputs(self._m, self._d, _vec(q, self.nq, "q"), out)
        return out

    def panel_jacobian(self, q) -> np.ndarray:
        """``d(panel outputs)/dq`` (tangent), shape (4 npanels, nv)."""
        J = np.zeros((4 * self.npanels, self.nv))
        self._eng.panel_jacobian(self._m, self._d, _vec(q, self.nq, "q"), J)
        return J

    def measure(self, q, v, t: float, jacobians: bool = False):
        """``z = [accel_B, arm_ddq]`` at ``(q, v, t)``; with ``jacobians`` also ``H``, ``Hu``, ``Hp``."""
        z = np.zeros(self.nz)
        H = Hu = Hp = None
        if jacobians:
            H, Hu, Hp = np.zeros((self.nz, self.nt)), np.zeros((self.nz, self.nu)), np.zeros((self.nz, self.np))
        self._eng.measure(self._m, self._d, _vec(q, self.nq, "q"), _vec(v, self.nv, "v"), float(t), z, H, Hu, Hp)
        return z, H, Hu, Hp

    # ------------------------------------------------------------------ integration
    def step(self, q, v, t: float, h: float):
        """One step; returns ``(q1, v1)``."""
        q1, v1 = _vec(q, self.nq, "q").copy(), _vec(v, self.nv, "v").copy()
        self._eng.step(self._m, self._d, q1, v1, float(t), float(h), None)
        return q1, v1

    def step_jacobian(self, q, v, t: float, h: float):
        """One step and its exact Jacobian: ``(q1, v1, Fx, Fu, Fp)``."""
        q1, v1 = _vec(q, self.nq, "q").copy(), _vec(v, self.nv, "v").copy()
        F, Fu, Fp = np.zeros((self.nt, self.nt)), np.zeros((self.nt, self.nu)), np.zeros((self.nt, self.np))
        self._eng.step_jacobian(self._m, self._d, q1, v1, float(t), float(h), F, Fu, Fp)
        return q1, v1, F, Fu, Fp

    def predict(self, q, v, t: float, h: float, n_steps: int, jacobians: bool, inputs: bool = False,
                frozen: bool = False):
        """``n_steps`` steps then the measurement: ``(q, v, z, F, Fu, Fp, H, Hu, Hp)``.

        The Jacobians are None without ``jacobians``, and ``Fu``, ``Hu`` (constant input offset) also
        without ``inputs`` (fewer columns to carry through the stages). With ``frozen`` the first step's
        Jacobian stands for every step's (``F = F1^n``, ``Fp = (I + F1 + ... + F1^(n-1)) Fp1``); the state
        still takes every step.
        """
        q1, v1 = _vec(q, self.nq, "q").copy(), _vec(v, self.nv, "v").copy()
        z = np.zeros(self.nz)
        out = [None] * 6
        if jacobians:
            nt, nz = self.nt, self.nz
            out = [np.zeros((nt, nt)), np.zeros((nt, self.nu)) if inputs else None, np.zeros((nt, self.np)),
                   np.zeros((nz, nt)), np.zeros((nz, self.nu)) if inputs else None, np.zeros((nz, self.np))]
        want = (2 if frozen else 1) if jacobians else 0
        self._eng.predict(self._m, self._d, q1, v1, float(t), float(h), int(n_steps), want, z, *out)
        return (q1, v1, z, *out)

    def simulate(self, q, v, t0: float, h: float, per_sample: int, n_samples: int, balance0=None, *,
                 sample_period: float | None = None, first_sample: int = 0):
        """Samples ``first_sample ..`` of a run whose sample k is at ``t0 + k sample_period``, ``per_sample``
        steps of ``h`` between samples (``sample_period`` defaults to ``h per_sample``).

        Returns a dict of sample-major histories: ``q``, ``v``, ``ddq``, ``panels`` (n, npanels, 4),
        ``mech`` (n, 11 + nz), ``balance`` (n, 7), ``u`` (n, nu), and the final ``(q, v)``.
        """
        q1, v1 = _vec(q, self.nq, "q").copy(), _vec(v, self.nv, "v").copy()
        n = int(n_samples)
        out = {
            "q": np.zeros((n, self.nq)), "v": np.zeros((n, self.nv)), "ddq": np.zeros((n, self.nv)),
            "panels": np.zeros((n, self.npanels, 4)), "mech": np.zeros((n, 11 + self.nz)),
            "balance": np.zeros((max(n, 1), 7)), "u": np.zeros((n, self.nu)),
        }
        if balance0 is not None:
            out["balance"][0] = balance0
        cancel = ctypes.c_int(0)
        sample = float(h * per_sample if sample_period is None else sample_period)
        self._eng.simulate(self._m, self._d, q1, v1, float(t0), sample, float(h), int(per_sample), int(first_sample), n,
                           out["q"], out["v"], out["ddq"], out["panels"], out["mech"], out["balance"], out["u"],
                           ctypes.byref(cancel))
        out["balance"] = out["balance"][:n]
        out["q_end"], out["v_end"] = q1, v1
        return out

    def sample(self, q, v, t: float):
        """What a run records at one sample: ``(ddq, panels (npanels, 4), mech (11 + nz), u)``."""
        ddq, panels, mech = np.zeros(self.nv), np.zeros((self.npanels, 4)), np.zeros(11 + self.nz)
        self._eng.sample(self._m, self._d, _vec(q, self.nq, "q"), _vec(v, self.nv, "v"), float(t), ddq, panels, mech)
        return ddq, panels, mech, self.inputs(t)


def _with_tableau(model: EngineModel, tableau) -> EngineModel:
    """The same packed model with another tableau (a new constant model)."""
    return EngineModel(model.ints, model.doubles, tableau, model.param_names)
