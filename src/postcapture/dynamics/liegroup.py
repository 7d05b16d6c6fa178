"""The configuration group in Python: box-plus, box-minus (the compiled core's) and the adjoint of se(3).

``integrate`` and ``difference`` call the core's ``pc_lie_integrate`` / ``pc_lie_difference`` (the one
implementation, ``csrc/pc_liegroup.c``); twists are ordered (linear, angular), perturbations are right
perturbations of the body twist, the free flyer's quaternion is stored (x, y, z, w).
"""

import numpy as np

__all__ = ["ad", "integrate", "difference"]


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


def _check(name: str, x, n: int) -> np.ndarray:
    a = np.ascontiguousarray(x, dtype=np.float64)
    if a.shape != (n,):
        from postcapture.core.errors import DimensionError

        raise DimensionError(f"{name}: expected shape ({n},), found {a.shape}")
    return a


def integrate(q, dq, nq: int, nv: int, free_flyer: bool) -> np.ndarray:
    """``q (+) dq`` for a configuration of ``nq`` entries (``nv`` tangent), free-flyer root or fixed base."""
    from postcapture.dynamics.engine import engine

    out = np.zeros(nq)
    engine().lie_integrate(nq, nv, int(free_flyer), _check("q", q, nq), _check("dq", dq, nv), out)
    return out


def difference(q0, q1, nq: int, nv: int, free_flyer: bool) -> np.ndarray:
    """``q1 (-) q0``: the tangent ``dq`` (nv,) with ``q0 (+) dq = q1``."""
    from postcapture.dynamics.engine import engine

    out = np.zeros(nv)
    engine().lie_difference(nq, nv, int(free_flyer), _check("q0", q0, nq), _check("q1", q1, nq), out)
    return out
