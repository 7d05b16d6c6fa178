"""The free flyer's Lie algebra se(3): the adjoint (the linearisation uses it).

Twists are ordered (linear, angular) as in Pinocchio.
"""

import numpy as np

__all__ = ["ad"]


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
