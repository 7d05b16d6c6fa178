"""The filters' coordinates for the plant's parameters, and the groups they are declared in.

A process model names its parameter vector ``p`` (:mod:`postcapture.dynamics.parameters`): the target
hub's ten inertial parameters ``target.*`` and factors ``<panel>.bending_scale``, ``.torsion_scale``,
``.damping_scale``, ``arm.stiffness_scale``, ``arm.damping_scale``. Filters work in unconstrained
coordinates ``eta`` that keep every value physical:

- the target's ten parameters through the log-Cholesky map of its pseudo-inertia
  (:mod:`postcapture.core.log_cholesky`): positive mass, positive definite inertia, triangle inequality;
- each factor through its logarithm (a factor stays positive).

Parameters come in the groups of the scenario's ``[uncertainty]``: ``target``, ``panel_bending``,
``panel_torsion``, ``panel_damping``, ``arm_stiffness``, ``arm_damping``. A filter estimates some groups
(augmented state) and considers others (Schmidt: their covariance enters the filter, their value is
never updated); the rest are known.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.core import log_cholesky as lc

__all__ = ["GROUPS", "group_of", "ParameterMap"]

GROUPS = ("target", "panel_bending", "panel_torsion", "panel_damping", "arm_stiffness", "arm_damping")
_SUFFIX = {".bending_scale": "panel_bending", ".torsion_scale": "panel_torsion", ".damping_scale": "panel_damping"}


def group_of(name: str) -> str:
    """The group of a model parameter name."""
    if name.startswith("target."):
        return "target"
    if name == "arm.stiffness_scale":
        return "arm_stiffness"
    if name == "arm.damping_scale":
        return "arm_damping"
    for suffix, group in _SUFFIX.items():
        if name.endswith(suffix):
            return group
    raise ValueError(f"parameter name: expected a target, panel or arm parameter, found {name!r}")


@dataclass(frozen=True)
class _Block:
    group: str
    model_index: tuple[int, ...]  # where the block's values sit in p
    labels: tuple[str, ...]  # its filter coordinates


class ParameterMap:
    """Filter coordinates ``eta`` of some parameter groups, and the model's parameter vector they give.

    Parameters
    ----------
    model_names : sequence of str
        The process model's parameter names.
    p_nominal : array_like
        The nominal parameter vector (the coordinates not in the map stay there).
    groups : sequence of str
        The groups the coordinates cover, in order (a group absent from the model is skipped).
    """

    def __init__(self, model_names, p_nominal, groups):
        self.model_names = tuple(model_names)
        self.p_nominal = np.array(p_nominal, dtype=float)
        unknown = [g for g in groups if g not in GROUPS]
        if unknown:
            raise ValueError(f"groups: expected names among {', '.join(GROUPS)}, found {', '.join(unknown)}")
        blocks = []
        for group in groups:
            index = tuple(i for i, n in enumerate(self.model_names) if group_of(n) == group)
            if not index:
                continue
            if group == "target":
                labels = tuple(f"target.{n}" for n in lc.THETA_NAMES)
            else:
                labels = tuple(f"log({self.model_names[i]})" for i in index)
            blocks.append(_Block(group, index, labels))
        self.blocks = tuple(blocks)
        self.labels = tuple(label for b in self.blocks for label in b.labels)
        self.size = len(self.labels)
        self.groups = tuple(b.group for b in self.blocks)

    def to_model(self, eta, p=None) -> np.ndarray:
        """The model's parameter vector for coordinates ``eta`` (others from ``p``, by default the nominal)."""
        out = (self.p_nominal if p is None else np.asarray(p, dtype=float)).copy()
        k = 0
        for b in self.blocks:
            n = len(b.labels)
            if b.group == "target":
                out[list(b.model_index)] = lc.pi_from_theta(eta[k : k + n])
            else:
                out[list(b.model_index)] = np.exp(eta[k : k + n])
            k += n
        return out

    def from_model(self, p) -> np.ndarray:
        """Coordinates of a (physical) parameter vector."""
        p = np.asarray(p, dtype=float)
        parts = []
        for b in self.blocks:
            values = p[list(b.model_index)]
            parts.append(lc.theta_from_pi(values) if b.group == "target" else np.log(values))
        return np.concatenate(parts) if parts else np.zeros(0)

    def jacobian(self, eta) -> np.ndarray:
        """``d p / d eta`` (n_p x size)."""
        J = np.zeros((self.p_nominal.size, self.size))
        k = 0
        for b in self.blocks:
            n = len(b.labels)
            rows = list(b.model_index)
            if b.group == "target":
                J[np.ix_(rows, range(k, k + n))] = lc.dpi_dtheta(eta[k : k + n])
            else:
                J[rows, range(k, k + n)] = np.exp(eta[k : k + n])
            k += n
        return J

    def slice(self, group: str) -> slice:
        """Where a group's coordinates sit in ``eta``."""
        k = 0
        for b in self.blocks:
            n = len(b.labels)
            if b.group == group:
                return slice(k, k + n)
            k += n
        raise KeyError(group)
