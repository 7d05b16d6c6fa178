"""The whole target's centre of mass and inertia from the filters' estimates of the hub's inertial parameters.

The recommended filters estimate the target hub's ten inertial parameters (frame T); an engineer asks for
the whole target (hub and undeformed panels) in the grasp frame G: its centre of mass (m, 3) and its
inertia about it (kg m^2, 6 components ``xx, yy, zz, xy, xz, yz``). Both the main job's ``results.nc``
(histories) and a campaign (final errors with the filter's 1-sigma) use these functions.
"""

from __future__ import annotations

import numpy as np

from postcapture.dynamics.truth import target_properties

__all__ = ["INERTIA_COMPONENTS", "whole_target", "target_history", "true_target", "target_errors"]

INERTIA_COMPONENTS = ("xx", "yy", "zz", "xy", "xz", "yz")
_ROWS, _COLS = [0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]


def whole_target(scenario, pi) -> np.ndarray:
    """``[com (3, m), inertia (6, kg m^2)]`` of the whole target in G, from the hub's parameters ``pi`` (10,)."""
    est = target_properties(scenario, pi)
    return np.concatenate([est.com, est.inertia[_ROWS, _COLS]])


def target_history(scenario, params) -> tuple[np.ndarray, np.ndarray]:
    """CoM (3, n) and inertia (6, n) histories from parameter histories ``params`` (>= 10, n); NaN where the
    estimate is not finite (a case that does not estimate the target gives all NaN)."""
    n = params.shape[-1]
    out = np.full((9, n), np.nan)
    for k in np.nonzero(np.all(np.isfinite(params[:10]), axis=0))[0]:
        out[:, k] = whole_target(scenario, params[:10, k])
    return out[:3], out[3:]


def true_target(truth: dict) -> tuple[np.ndarray, np.ndarray]:
    """The truth's CoM (3) and inertia (6) from its description (``TruthModel.describe`` or the truth vector by
    name); NaN when the scenario has no target."""
    com = np.array([truth.get(f"target_com_{a}", np.nan) for a in "xyz"], dtype=float)
    inertia = np.array([truth.get(f"target_I_{c}", np.nan) for c in INERTIA_COMPONENTS], dtype=float)
    return com, inertia


def target_errors(plan, res, truth_vec, names) -> dict:
    """Final errors of the whole target's centre of mass (m, 3, G frame) and inertia (kg m^2, 6), where
    estimated, with the filter's 1-sigma of each (its final covariance of the ten inertial parameters carried
    through the same map, to first order by central differences)."""
    nan = {"com_error": np.full(3, np.nan), "inertia_error": np.full(6, np.nan),
           "com_sigma": np.full(3, np.nan), "inertia_sigma": np.full(6, np.nan)}
    p = getattr(res, "params", None)
    if p is None or not np.all(np.isfinite(p[:10, -1])):
        return nan
    pi = p[:10, -1].copy()
    y = whole_target(plan.scenario, pi)
    true_c, true_I = true_target(dict(zip(names, truth_vec)))
    out = {**nan, "com_error": y[:3] - true_c, "inertia_error": y[3:] - true_I}
    C = getattr(res, "params_cov", None)
    if C is not None and np.all(np.isfinite(C[:10, :10])):
        J = np.empty((9, 10))
        for j in range(10):  # the map is smooth and cheap
            h = 1e-6 * max(abs(pi[j]), 1.0)
            e = np.zeros(10)
            e[j] = h
            J[:, j] = (whole_target(plan.scenario, pi + e) - whole_target(plan.scenario, pi - e)) / (2 * h)
        s = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", J, C[:10, :10], J), 0.0))
        out["com_sigma"], out["inertia_sigma"] = s[:3], s[3:]
    return out
