"""Pack a :class:`~postcapture.dynamics.system.System` into the compiled core's int and double arrays.

The layout is described in ``csrc/pc_model.c``. The same arrays are embedded in exported FMUs, so the
native core and an FMU are built from one description. The excitation profiles are packed by
:func:`postcapture.dynamics.excitation.pack_profiles` (re-exported here), the layout the core's
``pc_inputs_eval`` also reads. Also defined here: the plant's named parameter vector ``p`` (see
:func:`parameter_layout`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.dynamics.excitation import pack_profiles
from postcapture.dynamics.system import System

__all__ = ["LAYOUT_VERSION", "Packed", "pack_profiles", "ParameterLayout", "parameter_layout", "pack"]

LAYOUT_VERSION = 4
_KINDS = {"JointModelRX": 0, "JointModelRY": 1, "JointModelRZ": 2, "JointModelFreeFlyer": -1}


@dataclass(frozen=True)
class ParameterLayout:
    """The system's parameter vector (:mod:`postcapture.dynamics.parameters`) as the core sees it.

    ``spring_k[j]`` / ``spring_d[j]``: index of the parameter scaling spring j's stiffness / damping
    (-1: none; the Spong servos are not scaled).
    """

    names: tuple[str, ...]
    nominal: np.ndarray
    spring_k: tuple[int, ...]
    spring_d: tuple[int, ...]
    n_inertial: int


def parameter_layout(system: System) -> ParameterLayout:
    """The parameter vector of ``system`` at its current values."""

    def index(S: np.ndarray) -> tuple[int, ...]:
        return tuple(int(np.argmax(row)) if row.any() else -1 for row in S)

    n_inertial = 10 if system.layout.has_target else 0
    return ParameterLayout(tuple(system.parameter_names), system.parameters(), index(system._S_k),
                           index(system._S_d), n_inertial)


@dataclass(frozen=True)
class Packed:
    """The arrays of :func:`pack` and the facts the Python side needs to read the core's outputs."""

    ints: np.ndarray
    doubles: np.ndarray
    params: ParameterLayout


def pack(system: System) -> Packed:
    """The int and double arrays of ``system`` for ``pc_create`` (see ``csrc/pc_model.c``)."""
    model = system.model
    layout = system.layout
    nj = model.njoints - 1
    joints_i, joints_d = [], []
    for j in range(1, model.njoints):
        short = model.joints[j].shortname()
        if short not in _KINDS:
            raise ValueError(f"joint {model.names[j]!r}: unsupported type {short} (free flyer, RX, RY, RZ)")
        M = model.jointPlacements[j]
        joints_i += [int(model.parents[j]) - 1, _KINDS[short], model.joints[j].idx_q, model.joints[j].idx_v]
        joints_d += list(M.rotation.ravel()) + list(M.translation) + list(model.inertias[j].toDynamicParameters())
    sp = system.assembly.springs
    plist = parameter_layout(system)
    springs_i, springs_d = [], []
    r = system.n_root_v
    for j, row in enumerate(sp.rows):
        items = sorted(row.items())
        if len(items) > 2:
            raise ValueError(f"spring {sp.names[j]!r}: at most two coordinates per spring")
        idx = [r + e for e, _ in items] + [-1] * (2 - len(items))
        coef = [c for _, c in items] + [0.0] * (2 - len(items))
        springs_i += idx + [plist.spring_k[j], plist.spring_d[j]]
        springs_d += coef + [sp.k[j], sp.d[j], sp.rest[j]]
    nu = system.n_u
    u_to_v = [-1] * nu
    custom = bool(system._custom_B)
    if not custom:
        if layout.free_flyer:
            u_to_v[:6] = range(6)
        for i, iv in enumerate(layout.motor_v):
            u_to_v[6 + i] = int(iv)
    prof_i, prof_d, table_t, table_v = pack_profiles(system.inputs.profiles, layout.n_arm)
    panels_i, panels_d = [], []
    for p in layout.panels:
        root = model.frames[model.getFrameId(p.root_frame)]
        tip = model.frames[model.getFrameId(p.tip_frame)]
        panels_i += [int(root.parentJoint) - 1, int(tip.parentJoint) - 1, -1 if p.torsion_v is None else int(p.torsion_v)]
        panels_d += list(root.placement.rotation.ravel()) + list(root.placement.translation)
        panels_d += list(tip.placement.translation) + [p.length]
    r_acc = np.zeros(3)
    if model.existFrame("accelerometer"):
        r_acc = model.frames[model.getFrameId("accelerometer")].placement.translation.copy()
    t_L = np.zeros((10, 10))
    t_base = np.zeros(10)
    target_joint = -1
    if plist.n_inertial:
        target_joint = int(system._t_joint)
        t_L = system._t_L
        t_base = model.inertias[target_joint].toDynamicParameters() - t_L @ plist.nominal[:10]
        target_joint -= 1
    arm_v = [int(i) for i in layout.arm_v]
    header = [
        LAYOUT_VERSION, model.nq, model.nv, nj, nu, len(sp.rows), len(system.inputs.profiles), len(layout.panels),
        len(table_t), int(custom), layout.n_arm, len(arm_v), target_joint, len(plist.names), int(layout.free_flyer),
    ]
    ints = np.array(header + joints_i + springs_i + u_to_v + prof_i + panels_i + arm_v, dtype=np.int32)
    dbl = (
        joints_d + springs_d + (list(np.asarray(system.B, dtype=float).ravel()) if custom else []) + prof_d
        + table_t + table_v + panels_d + list(r_acc) + list(t_L.ravel()) + list(t_base) + list(plist.nominal)
    )
    return Packed(ints, np.asarray(dbl, dtype=float), plist)
