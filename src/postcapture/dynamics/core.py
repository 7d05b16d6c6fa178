"""The compiled plant core behind a Python object: one instance per plant copy (truth, each filter).

:class:`CompiledPlant` owns a ``pc_model_t`` built from :func:`postcapture.dynamics.packing.pack` and
exposes the core's calls on numpy arrays (float64, C order). Every call checks the core's status and
raises :class:`~postcapture.core.errors.SimulationError` with the core's message on failure.
"""

from __future__ import annotations

import ctypes

import numpy as np

from postcapture.core.errors import SimulationError
from postcapture.dynamics.compiled import load_library
from postcapture.dynamics.packing import pack
from postcapture.dynamics.system import System

__all__ = ["CompiledPlant", "MECH_FIELDS"]

MECH_FIELDS = ("com_N", "momentum_N", "angular_momentum_N", "energy_kinetic", "energy_elastic")


def _ptr(a: np.ndarray | None):
    return None if a is None else a.ctypes.data


def _vec(x, n: int, name: str) -> np.ndarray:
    a = np.ascontiguousarray(x, dtype=float)
    if a.shape != (n,):
        raise ValueError(f"{name}: expected shape ({n},), found {a.shape}")
    return a


class CompiledPlant:
    """A plant copy in the compiled core.

    Parameters
    ----------
    system : System
        The model to copy (its current parameters, springs, inputs and target mass).
    integrator : str or Tableau
        ``"sdirk3"`` (default), ``"sdirk2"``, ``"rk4"`` or any lower-triangular tableau.
    """

    def __init__(self, system: System, integrator="sdirk3"):
        from postcapture.dynamics.integrators import TABLEAUX

        self._lib = load_library()
        packed = pack(system)
        self.packed = packed
        self.param_names = packed.params.names
        ints, dbl = packed.ints, packed.doubles
        self._h = self._lib.pc_create(_ptr(ints), _ptr(dbl), ints.size, dbl.size)
        if not self._h:
            raise SimulationError("the compiled core refused the packed model (layout mismatch or no memory)")
        sizes = np.zeros(7, dtype=np.int32)
        self._lib.pc_sizes(self._h, _ptr(sizes))
        self.nq, self.nv, self.nu, self.np, self.nz, self.npanels, self.nj = (int(x) for x in sizes)
        self.nt = 2 * self.nv
        tab = TABLEAUX[integrator] if isinstance(integrator, str) else integrator
        self.set_tableau(tab)

    def __del__(self):
        h, lib = getattr(self, "_h", None), getattr(self, "_lib", None)
        if h and lib is not None:
            lib.pc_destroy(h)
            self._h = None

    # ------------------------------------------------------------------ settings
    def _check(self, status: int, what: str) -> None:
        if status:
            msg = self._lib.pc_error_message(self._h).decode(errors="replace")
            raise SimulationError(f"{what}: {msg}")

    def set_tableau(self, tableau) -> None:
        """Use a Butcher tableau (lower-triangular ``A``) for the following steps."""
        s = tableau.stages
        A = np.ascontiguousarray(tableau.A, dtype=float)
        b = np.ascontiguousarray(tableau.b, dtype=float)
        c = np.ascontiguousarray(tableau.c, dtype=float)
        self._check(self._lib.pc_set_tableau(self._h, s, _ptr(A), _ptr(b), _ptr(c)), "tableau")
        self.tableau = tableau

    def set_newton(self, rtol: float, atol: float, max_iter: int = 12) -> None:
        """Newton acceptance of the implicit stages (see ``csrc/pc_integrator.c``)."""
        self._lib.pc_set_newton(self._h, float(rtol), float(atol), int(max_iter))

    @property
    def params(self) -> np.ndarray:
        """The current parameter vector (see :class:`postcapture.dynamics.packing.ParameterLayout`)."""
        p = np.zeros(self.np)
        self._lib.pc_get_params(self._h, _ptr(p))
        return p

    def set_params(self, p) -> None:
        """Set the whole parameter vector."""
        p = _vec(p, self.np, "p")
        self._check(self._lib.pc_set_params(self._h, _ptr(p)), "parameters")

    def set_input_offset(self, u_extra=None) -> None:
        """A constant input added to the excitation in every following call (None: zero)."""
        self._lib.pc_set_input_offset(self._h, None if u_extra is None else _ptr(_vec(u_extra, self.nu, "u_extra")))

    def stats(self) -> dict:
        """Steps, Newton iterations and factorizations since the last reset."""
        out = np.zeros(3, dtype=np.int64)
        self._lib.pc_stats(self._h, _ptr(out))
        return {"steps": int(out[0]), "newton_iterations": int(out[1]), "factorizations": int(out[2])}

    # ------------------------------------------------------------------ dynamics
    def inputs(self, t: float, left: bool = False) -> np.ndarray:
        """The excitation (plus the input offset) at ``t``, shape (nu,)."""
        u = np.zeros(self.nu)
        self._lib.pc_inputs(self._h, float(t), int(left), _ptr(u))
        return u

    def aba(self, q, v, tau) -> np.ndarray:
        """``M^-1 (tau - b(q, v))`` (no springs)."""
        out = np.zeros(self.nv)
        self._check(self._lib.pc_aba(self._h, _ptr(_vec(q, self.nq, "q")), _ptr(_vec(v, self.nv, "v")),
                                     _ptr(_vec(tau, self.nv, "tau")), _ptr(out)), "aba")
        return out

    def rnea(self, q, v, a) -> np.ndarray:
        """Inverse dynamics ``M a + b(q, v)`` (no springs)."""
        out = np.zeros(self.nv)
        self._check(self._lib.pc_rnea(self._h, _ptr(_vec(q, self.nq, "q")), _ptr(_vec(v, self.nv, "v")),
                                      _ptr(_vec(a, self.nv, "a")), _ptr(out)), "rnea")
        return out

    def acceleration(self, q, v, u) -> np.ndarray:
        """``ddq`` with springs, dampers and the input vector ``u`` (nu,)."""
        out = np.zeros(self.nv)
        self._check(self._lib.pc_accel(self._h, _ptr(_vec(q, self.nq, "q")), _ptr(_vec(v, self.nv, "v")),
                                       _ptr(_vec(u, self.nu, "u")), _ptr(out)), "acceleration")
        return out

    def derivatives(self, q, v, u):
        """``ddq`` and its exact partials ``Aq`` (tangent), ``Av``, ``Au``, ``Ap``."""
        nv = self.nv
        ddq, Aq, Av = np.zeros(nv), np.zeros((nv, nv)), np.zeros((nv, nv))
        Au, Ap = np.zeros((nv, self.nu)), np.zeros((nv, self.np))
        self._check(self._lib.pc_derivatives(self._h, _ptr(_vec(q, self.nq, "q")), _ptr(_vec(v, nv, "v")),
                                             _ptr(_vec(u, self.nu, "u")), _ptr(ddq), _ptr(Aq), _ptr(Av), _ptr(Au),
                                             _ptr(Ap)), "derivatives")
        return ddq, Aq, Av, Au, Ap

    def mass_matrix(self, q) -> np.ndarray:
        """The joint-space mass matrix ``M(q)``."""
        M = np.zeros((self.nv, self.nv))
        self._check(self._lib.pc_mass_matrix(self._h, _ptr(_vec(q, self.nq, "q")), _ptr(M)), "mass matrix")
        return M

    def integrate(self, q, dq) -> np.ndarray:
        """``q (+) dq`` on the configuration group."""
        out = np.zeros(self.nq)
        self._lib.pc_integrate(self._h, _ptr(_vec(q, self.nq, "q")), _ptr(_vec(dq, self.nv, "dq")), _ptr(out))
        return out

    def measure(self, q, v, t: float, jacobians: bool = False):
        """``z = [accel_B, arm_ddq]`` at ``(q, v, t)``; with ``jacobians`` also ``H``, ``Hu``, ``Hp``."""
        z = np.zeros(self.nz)
        H = Hu = Hp = None
        if jacobians:
            H, Hu, Hp = np.zeros((self.nz, self.nt)), np.zeros((self.nz, self.nu)), np.zeros((self.nz, self.np))
        self._check(self._lib.pc_measure(self._h, _ptr(_vec(q, self.nq, "q")), _ptr(_vec(v, self.nv, "v")),
                                         float(t), _ptr(z), _ptr(H), _ptr(Hu), _ptr(Hp)), "measurement")
        return z, H, Hu, Hp

    # ------------------------------------------------------------------ integration
    def step(self, q, v, t: float, h: float):
        """One step; returns ``(q1, v1)``."""
        q1, v1 = _vec(q, self.nq, "q").copy(), _vec(v, self.nv, "v").copy()
        self._check(self._lib.pc_step(self._h, _ptr(q1), _ptr(v1), float(t), float(h), None), "step")
        return q1, v1

    def step_jacobian(self, q, v, t: float, h: float):
        """One step and its exact Jacobian: ``(q1, v1, Fx, Fu, Fp)``."""
        q1, v1 = _vec(q, self.nq, "q").copy(), _vec(v, self.nv, "v").copy()
        F, Fu, Fp = np.zeros((self.nt, self.nt)), np.zeros((self.nt, self.nu)), np.zeros((self.nt, self.np))
        self._check(self._lib.pc_step_jacobian(self._h, _ptr(q1), _ptr(v1), float(t), float(h), _ptr(F), _ptr(Fu),
                                               _ptr(Fp)), "step Jacobian")
        return q1, v1, F, Fu, Fp

    def predict(self, q, v, t: float, h: float, n_steps: int, jacobians: bool, inputs: bool = False):
        """``n_steps`` steps then the measurement: ``(q, v, z, F, Fu, Fp, H, Hu, Hp)``.

        The Jacobians are None without ``jacobians``, and ``Fu``, ``Hu`` (constant input offset) also
        without ``inputs`` (fewer columns to carry through the stages).
        """
        q1, v1 = _vec(q, self.nq, "q").copy(), _vec(v, self.nv, "v").copy()
        z = np.zeros(self.nz)
        out = [None] * 6
        if jacobians:
            nt, nz = self.nt, self.nz
            out = [np.zeros((nt, nt)), np.zeros((nt, self.nu)) if inputs else None, np.zeros((nt, self.np)),
                   np.zeros((nz, nt)), np.zeros((nz, self.nu)) if inputs else None, np.zeros((nz, self.np))]
        self._check(self._lib.pc_predict(self._h, _ptr(q1), _ptr(v1), float(t), float(h), int(n_steps), int(jacobians),
                                         _ptr(z), *(_ptr(a) for a in out)), "prediction")
        return (q1, v1, z, *out)

    def simulate(self, q, v, t0: float, h: float, per_sample: int, n_samples: int, balance0=None, *,
                 sample_period: float | None = None, first_sample: int = 0):
        """Samples ``first_sample ..`` of a run whose sample k is at ``t0 + k sample_period``, ``per_sample``
        steps of ``h`` between samples (``sample_period`` defaults to ``h per_sample``).

        Returns a dict of sample-major histories: ``q``, ``v``, ``ddq``, ``panels`` (n, npanels, 4),
        ``mech`` (n, 11), ``balance`` (n, 7), ``u`` (n, nu), and the final ``(q, v)``.
        """
        q1, v1 = _vec(q, self.nq, "q").copy(), _vec(v, self.nv, "v").copy()
        n = int(n_samples)
        out = {
            "q": np.zeros((n, self.nq)), "v": np.zeros((n, self.nv)), "ddq": np.zeros((n, self.nv)),
            "panels": np.zeros((n, self.npanels, 4)), "mech": np.zeros((n, 11 + self.nz)), "balance": np.zeros((n, 7)),
            "u": np.zeros((n, self.nu)),
        }
        if balance0 is not None:
            out["balance"][0] = balance0
        cancel = ctypes.c_int(0)
        sample = float(h * per_sample if sample_period is None else sample_period)
        self._check(self._lib.pc_simulate(self._h, _ptr(q1), _ptr(v1), float(t0), sample, float(h), int(per_sample),
                                          int(first_sample), n,
                                          _ptr(out["q"]), _ptr(out["v"]), _ptr(out["ddq"]), _ptr(out["panels"]),
                                          _ptr(out["mech"]), _ptr(out["balance"]), _ptr(out["u"]),
                                          ctypes.addressof(cancel)), "simulation")
        out["q_end"], out["v_end"] = q1, v1
        return out

    def sample(self, q, v, t: float):
        """What a run records at one sample: ``(ddq, panels (npanels, 4), mech (11 + nz), u)``."""
        ddq, panels, mech = np.zeros(self.nv), np.zeros((self.npanels, 4)), np.zeros(11 + self.nz)
        self._check(self._lib.pc_sample(self._h, _ptr(_vec(q, self.nq, "q")), _ptr(_vec(v, self.nv, "v")), float(t),
                                        _ptr(ddq), _ptr(panels), _ptr(mech)), "sample")
        return ddq, panels, mech, self.inputs(t)

    def reset_warm_start(self) -> None:
        """Forget the previous step's stages (the next step starts Newton cold) and the counters."""
        self._lib.pc_reset_stats(self._h)
