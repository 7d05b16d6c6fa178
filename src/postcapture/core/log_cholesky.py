r"""Physically consistent inertial parameters: the log-Cholesky parametrisation of the pseudo-inertia.

A rigid body's ten inertial parameters ``pi = [m, h_x, h_y, h_z, I_xx, I_xy, I_yy, I_xz, I_yz, I_zz]``
(Pinocchio's order: mass, first moment ``h = m c``, inertia about the frame origin) are those of a real
mass distribution exactly when the pseudo-inertia

.. math::

    J = \begin{bmatrix} \Sigma & h \\ h^T & m \end{bmatrix}, \qquad
    \Sigma = \tfrac12 \operatorname{tr}(I)\,\mathbf 1 - I

is positive definite (Wensing, Kim and Slotine, 2018): positive mass, positive definite inertia about
the centre of mass, and the triangle inequalities of its principal moments all follow. Writing
``J = U U^T`` with

.. math::

    U = e^{\alpha} \begin{bmatrix} e^{d_1} & s_{12} & s_{13} & t_1 \\ 0 & e^{d_2} & s_{23} & t_2 \\
                                   0 & 0 & e^{d_3} & t_3 \\ 0 & 0 & 0 & 1 \end{bmatrix}

maps any ``theta = (alpha, d1, d2, d3, s12, s23, s13, t1, t2, t3)`` in R^10 to a physical body and back
(Rucker and Wensing, "Smooth parameterization of rigid-body inertia", IEEE RA-L 7(2), 2022). The mass
is ``exp(2 alpha)``, so a 1-sigma of ``alpha`` is half the relative 1-sigma of the mass.

The map ``theta -> pi`` and its exact derivative run in the compiled engine with the filters
(``dynamics/csrc/pc_parameters.c``; :func:`postcapture.estimation.parameters.pi_from_theta` and
:func:`~postcapture.estimation.parameters.dpi_dtheta` call it); the inverse, used once to start a filter, is here.
"""

from __future__ import annotations

import numpy as np

__all__ = ["THETA_NAMES", "pseudo_inertia", "parameters_from_pseudo_inertia", "theta_from_pi"]

THETA_NAMES = ("alpha", "d1", "d2", "d3", "s12", "s23", "s13", "t1", "t2", "t3")
_SYM = ((0, 0), (0, 1), (1, 1), (0, 2), (1, 2), (2, 2))


def pseudo_inertia(pi) -> np.ndarray:
    """The 4 x 4 pseudo-inertia ``J`` of ten inertial parameters."""
    pi = np.asarray(pi, dtype=float)
    I = np.empty((3, 3))
    for k, (i, j) in enumerate(_SYM):
        I[i, j] = I[j, i] = pi[4 + k]
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(I) * np.eye(3) - I
    J[:3, 3] = J[3, :3] = pi[1:4]
    J[3, 3] = pi[0]
    return J


def _linear_map() -> np.ndarray:
    """The 10 x 16 matrix ``A`` with ``pi = A vec(J)`` (row-major ``vec``): ``m = J_33``, ``h = J[:3, 3]``,
    ``I = tr(Sigma) 1 - Sigma``."""
    A = np.zeros((10, 16))
    A[0, 15] = 1.0
    for r in range(3):
        A[1 + r, 4 * r + 3] = 1.0
    for k, (i, j) in enumerate(_SYM):
        if i == j:
            A[4 + k, [0, 5, 10]] = 1.0
        A[4 + k, 4 * i + j] -= 1.0
    return A


_A = _linear_map()


def parameters_from_pseudo_inertia(J) -> np.ndarray:
    """Ten inertial parameters of a pseudo-inertia (``I = tr(Sigma) 1 - Sigma``); linear in ``J``."""
    return _A @ np.asarray(J, dtype=float).reshape(16)


def theta_from_pi(pi) -> np.ndarray:
    """Log-Cholesky coordinates of physical inertial parameters.

    Raises
    ------
    ValueError
        If the pseudo-inertia is not positive definite (the parameters are not a physical body).
    """
    J = pseudo_inertia(pi)
    # U U^T with U upper triangular: the lower Cholesky factor of J with its rows and columns reversed
    P = np.eye(4)[::-1]
    try:
        L = np.linalg.cholesky(P @ J @ P)
    except np.linalg.LinAlgError:
        raise ValueError(f"inertial parameters of a body that cannot exist (pseudo-inertia not positive definite): {pi}") from None
    U = P @ L @ P
    a = np.log(U[3, 3])
    V = U / U[3, 3]
    return np.array([a, np.log(V[0, 0]), np.log(V[1, 1]), np.log(V[2, 2]), V[0, 1], V[1, 2], V[0, 2], V[0, 3], V[1, 3],
                     V[2, 3]])
