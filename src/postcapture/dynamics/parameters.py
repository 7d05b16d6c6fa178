"""The plant's named parameter vector: what estimators may estimate and what a truth may differ in.

``p`` holds, in this order:

1. the target hub's ten inertial parameters in the *nominal* target frame T (origin at the nominal
   target centre of mass, T's axes), in Pinocchio's ``Inertia.toDynamicParameters()`` order:
   ``target.m`` (kg), ``target.mc_x``, ``target.mc_y``, ``target.mc_z`` (kg m), ``target.I_xx``,
   ``target.I_xy``, ``target.I_yy``, ``target.I_xz``, ``target.I_yz``, ``target.I_zz`` (kg m^2, about T's
   origin). The hub is the rigid target body the model builds: the target minus its panels.
2. for every panel, chaser panels first, in scenario order: ``<panel>.bending_scale``,
   ``<panel>.torsion_scale`` (factors on its bending-hinge and torsion stiffnesses) and
   ``<panel>.damping_scale`` (factor on all its dampers); nominal 1;
3. ``arm.stiffness_scale`` and ``arm.damping_scale``: factors on every arm joint spring and damper
   (with Spong rotors, the joint's, not the servo's).

The inertial parameters enter the dynamics linearly (``M(pi) ddq + b(pi) = tau``), and the spring and
damper torques are linear in the scales: the compiled core's derivatives with respect to ``p`` are exact
(the tests hold them to Pinocchio's body regressor).
"""

from __future__ import annotations

import numpy as np

from postcapture.core.errors import DomainError
from postcapture.dynamics.bodies import MassProperties, parallel_axis

__all__ = [
    "INERTIAL_NAMES",
    "parameter_names",
    "dynamic_parameters",
    "mass_properties",
    "transform_matrix",
    "dmass_direction",
    "check_parameters",
    "with_target_mass",
]

INERTIAL_NAMES = ("m", "mc_x", "mc_y", "mc_z", "I_xx", "I_xy", "I_yy", "I_xz", "I_yz", "I_zz")
_SYM = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))  # Pinocchio's order of the six inertia entries


def parameter_names(panel_names, has_target: bool, has_arm: bool) -> tuple[str, ...]:
    """Names of the parameter vector of a model with these panels, target and arm."""
    names: list[str] = [f"target.{n}" for n in INERTIAL_NAMES] if has_target else []
    for p in panel_names:
        names += [f"{p}.bending_scale", f"{p}.torsion_scale", f"{p}.damping_scale"]
    if has_arm:
        names += ["arm.stiffness_scale", "arm.damping_scale"]
    return tuple(names)


def _sym(I: np.ndarray) -> np.ndarray:
    return np.array([I[i, j] for i, j in _SYM])


def _unsym(v) -> np.ndarray:
    I = np.empty((3, 3))
    for k, (i, j) in enumerate(_SYM):
        I[i, j] = I[j, i] = v[k]
    return I


def dynamic_parameters(props: MassProperties) -> np.ndarray:
    """Ten inertial parameters ``[m, m c, I about the origin]`` of a body given by mass, CoM and inertia about the CoM."""
    m, c = props.mass, props.com
    return np.concatenate([[m], m * c, _sym(props.inertia + parallel_axis(m, c))])


def mass_properties(pi) -> MassProperties:
    """Mass (kg), centre of mass (m) and inertia about the centre of mass (kg m^2) of ten inertial parameters."""
    pi = np.asarray(pi, dtype=float)
    m = float(pi[0])
    c = pi[1:4] / m
    return MassProperties(m, c, _unsym(pi[4:]) - parallel_axis(m, c))


def transform_matrix(R, p) -> np.ndarray:
    """The 10 x 10 matrix taking a body's inertial parameters in a child frame to those in its parent.

    The child frame has rotation ``R`` (child to parent components) and origin ``p`` in the parent. With
    ``h = m c`` the first moment, ``h' = R h + m p`` and the inertia about the parent's origin is
    ``R I R^T - m [p]x^2 - [p]x [R h]x - [R h]x [p]x``: linear in the ten parameters.
    """
    R = np.asarray(R, dtype=float)
    p = np.asarray(p, dtype=float)

    def skew(w):
        return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])

    P = skew(p)
    L = np.zeros((10, 10))
    L[0, 0] = 1.0
    L[1:4, 0] = p
    L[1:4, 1:4] = R
    L[4:, 0] = _sym(-P @ P)
    for k in range(3):  # first-moment columns
        Rh = skew(R[:, k])
        L[4:, 1 + k] = _sym(-P @ Rh - Rh @ P)
    for k, (i, j) in enumerate(_SYM):  # inertia columns: R E R^T with E the unit symmetric entry
        E = np.zeros((3, 3))
        E[i, j] = E[j, i] = 1.0
        L[4:, 4 + k] = _sym(R @ E @ R.T)
    return L


def dmass_direction(pi) -> np.ndarray:
    """``d pi / d m`` at a fixed centre of mass and a fixed inertia about it, shape (10,):
    ``[1, c, |c|^2 I - c c^T]`` with ``c = (m c) / m``; the engine's (``pc_refdual.c``), which the reference-dual
    estimator FMU also runs."""
    from postcapture.dynamics.engine import engine

    out = np.zeros(10)
    engine().dmass_direction(np.ascontiguousarray(pi[:10], dtype=float), out)
    return out


def check_parameters(names, p, has_target: bool) -> np.ndarray:
    """``p`` as a validated parameter vector named ``names`` (a read-write copy).

    Raises
    ------
    DomainError
        If ``p`` has the wrong length, is not finite, or gives a non-physical target (mass <= 0, inertia
        about its centre of mass not positive definite) or a negative scale.
    """
    p = np.array(p, dtype=float).reshape(-1)
    n_p = len(names)
    if p.shape != (n_p,) or not np.all(np.isfinite(p)):
        raise DomainError(f"parameters: expected {n_p} finite numbers ({', '.join(names)}), found {p}")
    n_i = 10 if has_target else 0
    if np.any(p[n_i:] < 0.0):
        bad = [n for n, x in zip(names[n_i:], p[n_i:]) if x < 0]
        raise DomainError(f"parameters: expected scales >= 0, found negative {', '.join(bad)}")
    if n_i:
        props = mass_properties(p[:10]) if p[0] > 0 else None
        if props is None or np.linalg.eigvalsh(props.inertia)[0] <= 0.0:
            raise DomainError(f"parameters: expected a target hub with positive mass and positive definite "
                              f"inertia about its centre of mass, found {p[:10]}")
    return p


def with_target_mass(p, total_mass: float, panel_mass: float) -> np.ndarray:
    """The parameter vector with the target's total mass (hub plus ``panel_mass`` of panels) set to
    ``total_mass``: the hub's mass moves at a fixed centre of mass and a fixed inertia about it (the one
    place this split is computed: ``pc_target_mass`` in the engine)."""
    m_hub = float(total_mass) - panel_mass
    if not m_hub > 0.0:
        raise ValueError(f"target_mass: expected more than the panels' {panel_mass} kg, found {total_mass}")
    from postcapture.dynamics.engine import engine

    p = np.array(p, dtype=float)
    if not p[0] > 0.0:
        raise ValueError(f"target.m: expected a hub of positive mass to move, found {p[0]}")
    out = np.zeros(10)
    engine().target_mass(np.ascontiguousarray(p[:10]), m_hub, out)  # the engine's, as the estimator FMU runs it
    p[:10] = out
    return p
