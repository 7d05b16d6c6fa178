"""Calibration errors of a sensor triad: scale factors and misalignments (the datasheet's terms).

A triad reads a body-frame vector ``w`` as ``C w`` with ``C = I + diag(s) + M``: ``s`` (3,) the axes'
relative scale-factor errors (1e-6 is 1 ppm) and ``M`` (3, 3, zero diagonal) each axis's sensitivity
to the two others (rad, small angles). As a vector, ``c = (s, m)`` with ``m`` the six off-diagonal terms
of ``M`` in row-major order (``xy, xz, yx, yz, zx, zy``). The sensors apply it here (:func:`axis_matrix`); the
filters' model of it (``C`` of a calibration vector and its sensitivity) is the compiled engine's, reached
through :mod:`postcapture.estimation.increments`.
"""

from __future__ import annotations

import numpy as np

__all__ = ["OFF_DIAGONAL", "CALIBRATION_LABELS", "axis_matrix"]

OFF_DIAGONAL = ((0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1))
CALIBRATION_LABELS = ("scale_x", "scale_y", "scale_z") + tuple(f"misalignment_{'xyz'[i]}{'xyz'[j]}"
                                                               for i, j in OFF_DIAGONAL)


def axis_matrix(scale_factor, misalignment) -> np.ndarray:
    """``I + diag(scale_factor) + misalignment`` (3, 3) from the scale factors (3,) and the matrix ``M``."""
    return np.eye(3) + np.diag(np.asarray(scale_factor, dtype=float)) + np.asarray(misalignment, dtype=float)
