r"""Identification of the chain's hinge stiffnesses from reference modes (the reference's section 3).

The bending stiffnesses ``k`` (N m/rad, root to tip) of the lumped chain are fitted to the first
``n`` bending modes of a reference (the FEM, an OP2 file, or another chain) by weighted Gauss-Newton,

.. math::

    \min_p \; e(p)^T W(w) \, e(p), \qquad k = \exp(p),

so that every iterate is positive. The torsion stiffness follows in closed form from the first torsion
frequency.

Residuals ``e`` (dimensionless, ``n (1 + 2N)`` of them)
-----------------------------------------------------
* Frequencies: ``f_r / f_r^ref - 1`` for the ``n`` paired modes (relative errors).
* Shapes: for each paired mode the sampled shape
  ``y = [w(s_1) ... w(s_N), L slope(m_1) ... L slope(m_N)]`` with ``w`` at the hinge stations
  outboard of the root and the tip (``s_j = j L / N``) and the slope ``dw/dx`` at the segment
  midpoints ``m_j = (j - 1/2) L / N``, scaled by the length ``L`` so that both halves are lengths;
  both vectors are normalised to unit length and the chain's sign is aligned with the reference's,
  and the residual is their difference (``|u - u_ref|^2 = 2 (1 - sqrt(MAC))``).

The slopes are sampled at the midpoints because that is where a rigid segment's slope stands for the
beam's: with the hinge cells of `postcapture.config.flexibility` a chain under a uniform moment has
exactly the beam's deflection at the hinges and the beam's slope at the segment midpoints, while at a
hinge the chain's slope jumps. (Sampling the slope at the hinges, as the mean of both sides, tripled
``1 - MAC`` of the third Euler-Bernoulli mode of a uniform five-segment chain.)

Weights ``W(w)``
----------------
``W = diag(1, ..., 1, w, ..., w)``: one for each of the ``n`` frequency rows and ``w`` for each of the
``2 N n`` shape rows, so ``w`` weighs the shapes against the frequencies and a small ``w`` makes the
frequencies dominate. The reference reports that ``w = 0.1`` matched the FEM's first resonance best
and explains the failures of ``w = 1`` and ``10`` by frequency errors being underweighted, which is
this reading. Shapes do not depend on a common scale of ``k``, so the frequencies alone set the level
of the stiffnesses and the shapes mostly their distribution along the panel.

Pairing and Jacobian
--------------------
At each iterate every reference mode is paired with a distinct chain bending mode by maximum total
MAC (``scipy.optimize.linear_sum_assignment``). The Jacobian is analytic: with mass-normalised
eigenvectors ``phi`` of ``K(k) phi = lambda M phi`` in the bending angles (``M`` independent of ``k``,
``dK/dk_j = e_j e_j^T`` since each hinge spring acts on its own angle, which `LumpedChain` checks),

.. math::

    \frac{\partial \lambda_c}{\partial p_j} = k_j \phi_{jc}^2, \qquad
    \frac{\partial \phi_c}{\partial p_j} = k_j \sum_{s \ne c} \phi_s
        \frac{\phi_{js} \phi_{jc}}{\lambda_c - \lambda_s}

(Fox and Kapoor's modal expansion, exact here because all N bending modes of the chain are known
and the mass matrix does not depend on ``k``), then the chain rule through the frequency and the
unit normalisation. Steps are Gauss-Newton steps (least-squares solve of the weighted Jacobian)
with backtracking on the cost.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from postcapture.config.flexibility import stiffness_from_ei
from postcapture.core.errors import PanelModelError, Problem
from postcapture.panels.lumped import LumpedChain, LumpedModes, centreline_maps
from postcapture.panels.modes import PanelModes

__all__ = ["BETA1_L", "ModalTarget", "IdentificationResult", "modal_assurance", "shape_vectors",
           "initial_stiffness", "torsion_stiffness", "identify_stiffness"]

logger = logging.getLogger(__name__)

BETA1_L = 1.8751040687119611
"""First root of ``cos(b) cosh(b) = -1`` (clamped-free Euler-Bernoulli beam) (-)."""


def modal_assurance(a, b) -> np.ndarray:
    """Modal assurance criterion between two sets of real shape vectors.

    Parameters
    ----------
    a : array_like, shape (n_dof, n_a)
    b : array_like, shape (n_dof, n_b)

    Returns
    -------
    ndarray, shape (n_a, n_b)
        ``(a_i . b_j)^2 / ((a_i . a_i) (b_j . b_j))``, in ``[0, 1]`` (-).
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return (a.T @ b) ** 2 / np.outer(np.einsum("ij,ij->j", a, a), np.einsum("ij,ij->j", b, b))


def shape_vectors(w, slope, length: float) -> np.ndarray:
    """Stack the sampled displacements and length-scaled slopes, one unit column per mode.

    Parameters
    ----------
    w : array_like, shape (N, n)
        Displacements at the hinge stations and the tip (any consistent unit).
    slope : array_like, shape (N, n)
        Slopes at the segment midpoints (the same unit per metre).
    length : float
        Panel length ``L`` (m).

    Returns
    -------
    ndarray, shape (2 N, n)
        ``[w; L slope]`` normalised to unit 2-norm per column (-).
    """
    y = np.vstack([np.asarray(w, dtype=float), length * np.asarray(slope, dtype=float)])
    return y / np.linalg.norm(y, axis=0)


@dataclass(frozen=True)
class ModalTarget:
    """The reference modes the chain is fitted to, sampled for an N-segment chain.

    Attributes
    ----------
    length : float
        Panel length (m).
    segments : int
        Number of chain segments ``N`` the samples are for.
    bending_hz : ndarray, shape (n,)
        Frequencies of the first ``n`` reference bending modes (Hz).
    w : ndarray, shape (N, n)
        Their displacements at the stations ``s_j = j L / N``, j = 1..N (m/sqrt(kg) or any unit).
    slope : ndarray, shape (N, n)
        Their slopes at the midpoints ``(j - 1/2) L / N`` (the unit of ``w`` per metre).
    torsion_hz : float
        Frequency of the first reference torsion mode (Hz); NaN when unknown.
    """

    length: float
    segments: int
    bending_hz: np.ndarray
    w: np.ndarray
    slope: np.ndarray
    torsion_hz: float = float("nan")

    @property
    def n_modes(self) -> int:
        """Number of bending modes ``n``."""
        return self.bending_hz.size

    @property
    def vectors(self) -> np.ndarray:
        """Unit shape vectors `shape_vectors`, shape (2 N, n) (-)."""
        return shape_vectors(self.w, self.slope, self.length)

    @staticmethod
    def stations(length: float, segments: int) -> tuple[np.ndarray, np.ndarray]:
        """Return the displacement stations ``j L / N`` (j = 1..N) and slope stations (midpoints) (m)."""
        l = length / segments
        return l * np.arange(1, segments + 1), l * (np.arange(segments) + 0.5)

    @classmethod
    def from_panel_modes(cls, modes: PanelModes, segments: int, *, n_bending: int = 3) -> ModalTarget:
        """Sample the first bending modes of plate modes (FEM or OP2) along the centreline.

        Raises
        ------
        PanelModelError
            If ``segments`` or ``n_bending`` is not a positive integer, or the modes hold no bending mode.
        """
        _check_count("segments", segments)
        _check_count("n_bending", n_bending)
        idx = modes.indices("bending")[:n_bending]
        if idx.size == 0:
            raise PanelModelError([Problem("reference", "at least one bending mode", "none")])
        length = modes.mesh.geometry.length
        s_w, s_slope = cls.stations(length, segments)
        w, _ = modes.centreline(s_w, idx)
        _, slope = modes.centreline(s_slope, idx)
        tors = modes.indices("torsion")
        return cls(length=float(length), segments=int(segments), bending_hz=modes.frequencies_hz[idx].copy(),
                   w=w, slope=slope,
                   torsion_hz=float(modes.frequencies_hz[tors[0]]) if tors.size else float("nan"))

    @classmethod
    def from_lumped_modes(cls, modes: LumpedModes, *, segments: int | None = None,
                          n_bending: int = 3) -> ModalTarget:
        """Sample the first bending modes of a chain (a closed-loop reference) for ``segments`` (default N).

        Raises
        ------
        PanelModelError
            If ``segments`` or ``n_bending`` is not a positive integer.
        """
        n = modes.segments if segments is None else segments
        _check_count("segments", n)
        _check_count("n_bending", n_bending)
        idx = modes.indices("bending")[:n_bending]
        s_w, s_slope = cls.stations(modes.length, n)
        w, _ = modes.centreline(s_w, idx)
        _, slope = modes.centreline(s_slope, idx)
        return cls(length=modes.length, segments=int(n), bending_hz=modes.frequencies_hz[idx].copy(), w=w,
                   slope=slope, torsion_hz=modes.frequency("torsion"))


def _check_count(name: str, value) -> None:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise PanelModelError([Problem(name, "an integer >= 1", repr(value))])


@dataclass(frozen=True)
class IdentificationResult:
    """Outcome of `identify_stiffness`.

    Attributes
    ----------
    weight : float
        The shape weight ``w`` (-).
    k : ndarray, shape (N,)
        Fitted hinge stiffnesses, root to tip (N m/rad).
    frequencies_hz : ndarray, shape (n,)
        Chain frequencies paired with the reference's bending modes (Hz).
    mac : ndarray, shape (n,)
        MAC of each paired mode on the sampled shape vectors (-).
    pairing : ndarray of int, shape (n,)
        Index of the chain bending mode (ascending frequency) paired with each reference mode.
    cost : float
        Final ``e^T W e`` (-).
    iterations : int
        Gauss-Newton iterations taken.
    converged : bool
        Whether the step fell below ``xtol`` (or the cost stopped decreasing at round-off).
    message : str
        Why the iteration stopped.
    history : list of float
        Cost at each iterate.
    """

    weight: float
    k: np.ndarray
    frequencies_hz: np.ndarray
    mac: np.ndarray
    pairing: np.ndarray
    cost: float
    iterations: int
    converged: bool
    message: str
    history: list = field(default_factory=list)


def initial_stiffness(target: ModalTarget, mass_per_length: float) -> np.ndarray:
    """Uniform-beam starting stiffnesses that put a continuous beam's first mode at the reference's.

    Parameters
    ----------
    target : ModalTarget
        The reference (its length, number of segments and first bending frequency).
    mass_per_length : float
        Mass per unit length of the chain (kg/m).

    Returns
    -------
    ndarray, shape (N,)
        `stiffness_from_ei` of the uniform ``EI = mu L^4 (2 pi f_1 / beta_1^2)^2`` (Euler-Bernoulli)
        (N m/rad).
    """
    ei = mass_per_length * target.length**4 * (2.0 * math.pi * target.bending_hz[0] / BETA1_L**2) ** 2
    return stiffness_from_ei([0.0, target.length], [ei], target.length, target.segments)


def torsion_stiffness(chain: LumpedChain, torsion_hz: float) -> float:
    """Torsion spring that puts the chain's torsion mode at ``torsion_hz``.

    Parameters
    ----------
    chain : LumpedChain
        The chain (its mass matrix).
    torsion_hz : float
        Target frequency (Hz), > 0.

    Returns
    -------
    float
        ``k_t = (2 pi f_t)^2 I_t`` (N m/rad) with ``I_t`` the chain's mass-matrix entry of the torsion
        hinge: torsion is decoupled from bending at rest, so the torsion mode is the single-DoF
        oscillator ``I_t theta'' + k_t theta = 0``.

    Raises
    ------
    PanelModelError
        If the frequency is not positive and finite.
    """
    ok = isinstance(torsion_hz, (int, float, np.floating)) and math.isfinite(torsion_hz) and torsion_hz > 0
    if not ok:
        raise PanelModelError([Problem("torsion_hz", "a finite frequency > 0 Hz (a torsion mode in the "
                                       "reference)", repr(torsion_hz))])
    return float((2.0 * math.pi * torsion_hz) ** 2 * chain.torsion_inertia)


class _Problem:
    """Residuals and Jacobian of the weighted fit for one chain and target."""

    def __init__(self, chain: LumpedChain, target: ModalTarget, weight: float):
        self.chain = chain
        self.target = target
        self.sqrt_w = math.sqrt(weight)
        n = chain.segments
        s_w, s_slope = ModalTarget.stations(target.length, n)
        w_map, _ = centreline_maps(target.length, n, s_w)
        _, slope_map = centreline_maps(target.length, n, s_slope)
        self.sampling = np.vstack([w_map, target.length * slope_map])  # (2N, N): angles -> y
        self.y_ref = target.vectors

    def evaluate(self, p: np.ndarray, jacobian: bool = True):
        k = np.exp(p)
        lam, phi = self.chain.bending_eigen(k)
        lam = np.maximum(lam, 1e-300)
        y = self.sampling @ phi
        norm = np.linalg.norm(y, axis=0)
        mac = modal_assurance(self.y_ref, y)
        _, pair = linear_sum_assignment(-mac)
        f_ref = self.target.bending_hz
        f = np.sqrt(lam[pair]) / (2.0 * math.pi)
        e_f = f / f_ref - 1.0
        units, signs = [], []
        for r, c in enumerate(pair):
            sign = 1.0 if y[:, c] @ self.y_ref[:, r] >= 0.0 else -1.0
            units.append(sign * y[:, c] / norm[c])
            signs.append(sign)
        u = np.column_stack(units)
        e = np.concatenate([e_f, self.sqrt_w * (u - self.y_ref).T.ravel()])
        out = {"k": k, "f": f, "mac": mac[np.arange(pair.size), pair], "pair": pair, "e": e}
        if jacobian:
            n = k.size
            d_lam = k[None, :] * phi.T**2  # (mode, j): d lambda / d p_j
            rows_f = (f / (2.0 * lam[pair]) / f_ref)[:, None] * d_lam[pair]
            gap = lam[:, None] - lam[None, :]
            np.fill_diagonal(gap, np.inf)
            inv_gap = 1.0 / gap  # (c, s)
            rows_s = []
            for r, c in enumerate(pair):
                # d phi_c / d p_j = k_j phi_jc sum_s phi_s phi_js / (lam_c - lam_s)
                d_phi = phi @ (inv_gap[c][:, None] * phi.T) * (k * phi[:, c])[None, :]
                d_y = self.sampling @ d_phi
                d_u = signs[r] * (d_y - np.outer(u[:, r], u[:, r] @ d_y)) / norm[c]
                rows_s.append(self.sqrt_w * d_u)
            out["J"] = np.vstack([rows_f] + rows_s) if n else None
        return out


def identify_stiffness(chain: LumpedChain, target: ModalTarget, *, weight: float = 0.1, k0=None,
                       max_iter: int = 100, xtol: float = 1e-10) -> IdentificationResult:
    """Fit the chain's bending stiffnesses to reference modes by weighted Gauss-Newton.

    Parameters
    ----------
    chain : LumpedChain
        The chain (length, width, mass and N; its own stiffnesses are not used).
    target : ModalTarget
        Reference modes sampled for ``chain.segments`` segments; at most N of its modes are fitted.
    weight : float, optional
        Shape weight ``w`` > 0 (see the module text). Default 0.1.
    k0 : array_like, shape (N,), optional
        Starting stiffnesses (N m/rad), > 0; default `initial_stiffness` scaled by the chain's mass
        per length.
    max_iter : int, optional
        Iteration limit. Default 100.
    xtol : float, optional
        Convergence when the largest step in ``log k`` is below it. Default 1e-10.

    Returns
    -------
    IdentificationResult
        ``converged`` is False (and a warning is logged) when ``max_iter`` is reached.

    Raises
    ------
    PanelModelError
        If the weight is not positive and finite, ``k0`` has the wrong length or non-positive
        entries, or the target is sampled for another number of segments.
    """
    problems = []
    if not (isinstance(weight, (int, float, np.floating)) and math.isfinite(weight) and weight > 0):
        problems.append(Problem("weight", "a finite weight > 0", repr(weight)))
    n = chain.segments
    if target.segments != n:
        problems.append(Problem("target.segments", f"{n} (the chain's)", str(target.segments)))
    if k0 is None:
        k_start = initial_stiffness(target, chain.panel.mass / chain.panel.length)
    else:
        k_start = np.atleast_1d(np.asarray(k0, dtype=float))
        if k_start.shape != (n,) or not np.all(np.isfinite(k_start)) or np.any(k_start <= 0):
            problems.append(Problem("k0", f"{n} finite stiffnesses > 0 N m/rad", repr(k0)))
    if problems:
        raise PanelModelError(problems)
    if target.n_modes > n:
        target = ModalTarget(target.length, n, target.bending_hz[:n], target.w[:, :n], target.slope[:, :n],
                             target.torsion_hz)
    prob = _Problem(chain, target, float(weight))
    p = np.log(k_start)
    cur = prob.evaluate(p)
    cost = float(cur["e"] @ cur["e"])
    history = [cost]
    converged, message, it = False, f"reached max_iter = {max_iter}", 0
    for it in range(1, max_iter + 1):
        e, J = cur["e"], cur["J"]
        dp = np.linalg.lstsq(J, -e, rcond=None)[0]
        slope = 2.0 * float(e @ (J @ dp))  # directional derivative of the cost (< 0 for a GN step)
        t, accepted = 1.0, None
        while t >= 1e-10:
            trial = prob.evaluate(p + t * dp)
            c_trial = float(trial["e"] @ trial["e"])
            if c_trial <= cost + 1e-4 * t * slope:
                accepted = trial
                break
            t *= 0.5
        if accepted is None:
            converged = np.max(np.abs(dp)) < 1e-6 or cost < 1e-28
            message = "no decrease along the Gauss-Newton step (round-off floor)" if converged else \
                "line search failed"
            break
        p = p + t * dp
        cur, cost = accepted, c_trial
        history.append(cost)
        if np.max(np.abs(t * dp)) < xtol:
            converged, message = True, f"step below xtol = {xtol:g}"
            break
    if not converged:
        logger.warning("stiffness identification (w = %g) did not converge: %s", weight, message)
    final = prob.evaluate(p, jacobian=False)
    return IdentificationResult(weight=float(weight), k=final["k"], frequencies_hz=final["f"],
                                mac=final["mac"], pairing=final["pair"], cost=float(final["e"] @ final["e"]),
                                iterations=it, converged=bool(converged), message=message, history=history)
