"""Helpers shared by the FMI tests."""

import numpy as np

__all__ = ["tight_native", "rel"]


def tight_native(system, step, integrator="sdirk3"):
    """A native process model whose Newton iterations converge to round-off (the FMU's do)."""
    from postcapture.dynamics.process_model import NativeProcessModel

    pm = NativeProcessModel(system, step, integrator)
    pm.integrator.newton_tol = 1e-15
    pm.integrator.reuse_jacobian = 1
    return pm


def rel(a, b) -> float:
    """Largest entry difference relative to the largest entry of the reference."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / np.abs(b).max())
