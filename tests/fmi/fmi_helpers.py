"""Helpers shared by the FMI tests."""

import numpy as np

__all__ = ["native_model", "rel"]


def native_model(system, step, integrator="sdirk3"):
    """The native process model with its default settings: it runs the same compiled core as the FMU."""
    from postcapture.dynamics.process_model import NativeProcessModel

    return NativeProcessModel(system, step, integrator)


def rel(a, b) -> float:
    """Largest entry difference relative to the largest entry of the reference."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return float(np.abs(a - b).max() / np.abs(b).max())
