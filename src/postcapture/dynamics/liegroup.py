"""The free flyer's Lie algebra se(3): the adjoint and the inverse differential of the exponential.

A configuration near ``q_k`` is written ``q = q_k (+) xi`` (Pinocchio's ``integrate``, which for the free
flyer is ``q_k exp(xi)`` on SE(3)). With the body twist ``V`` the chart coordinate obeys

    d xi / dt = dexp^{-1}_{-xi}(V) = V + 1/2 [xi, V] + 1/12 [xi, [xi, V]] - 1/720 ad_xi^4 V + ...

(Bernoulli numbers; Iserles, Munthe-Kaas, Norsett, Zanna, Acta Numerica 2000). Inside a step
``xi = O(h)``, so cutting the series after the ad^2 term leaves an O(h^5) local error: Runge-Kutta-
Munthe-Kaas methods up to order 4 keep their order (Munthe-Kaas, BIT 39, 1999). The same truncated map
is used in the integrator's residuals and in their derivatives, so step Jacobians are exact derivatives
of the step actually taken.

Twists are ordered (linear, angular) as in Pinocchio.
"""

import numpy as np

__all__ = ["ad", "dexpinv", "dexpinv_apply", "dexpinv_dxi"]


def ad(xi: np.ndarray) -> np.ndarray:
    """Matrix of ``ad_xi`` on se(3): ``ad(xi) @ V == [xi, V]`` (6x6)."""
    rx, ry, rz, px, py, pz = xi
    P = np.array([[0.0, -pz, py], [pz, 0.0, -px], [-py, px, 0.0]])
    R = np.array([[0.0, -rz, ry], [rz, 0.0, -rx], [-ry, rx, 0.0]])
    out = np.zeros((6, 6))
    out[:3, :3] = P
    out[:3, 3:] = R
    out[3:, 3:] = P
    return out


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
