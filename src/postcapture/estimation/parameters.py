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

The map ``eta -> p`` and its derivative are computed by the compiled engine (``pc_parameters.c``), which
the filters run.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.core import log_cholesky as lc
from postcapture.dynamics import engine as _engine

__all__ = ["GROUPS", "group_of", "ParameterMap", "pi_from_theta", "dpi_dtheta"]

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


def pi_from_theta(theta) -> np.ndarray:
    """Inertial parameters of log-Cholesky coordinates (always a physical body; :mod:`postcapture.core.log_cholesky`)."""
    pi = np.zeros(10)
    _engine.engine().log_cholesky(np.ascontiguousarray(theta, dtype=float), pi, None)
    return pi


def dpi_dtheta(theta) -> np.ndarray:
    """Jacobian ``d pi / d theta`` (10 x 10), exact: ``dJ = dU U^T + U dU^T`` and ``pi`` is linear in ``J``."""
    J = np.zeros((10, 10))
    _engine.engine().log_cholesky(np.ascontiguousarray(theta, dtype=float), None, J)
    return J


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
        self._spec = self.spec

    @property
    def spec(self) -> np.ndarray:
        """The map as the engine reads it: ``[n_blocks, then per block: kind (0 log-Cholesky, 1 log), size,
        the model indices]`` (int32)."""
        out = [len(self.blocks)]
        for b in self.blocks:
            out += [0 if b.group == "target" else 1, len(b.model_index), *b.model_index]
        return np.asarray(out, dtype=np.int32)

    def to_model(self, eta, p=None) -> np.ndarray:
        """The model's parameter vector for coordinates ``eta`` (others from ``p``, by default the nominal)."""
        out = np.zeros(self.p_nominal.size)
        base = self.p_nominal if p is None else np.asarray(p, dtype=float)
        _engine.engine().parammap_apply(self._spec, np.ascontiguousarray(base), base.size,
                                        np.ascontiguousarray(eta, dtype=float), out, None)
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
        _engine.engine().parammap_apply(self._spec, self.p_nominal, self.p_nominal.size,
                                        np.ascontiguousarray(eta, dtype=float), None, J)
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
