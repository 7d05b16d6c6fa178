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

__all__ = ["Packed", "pack_profiles", "ParameterLayout", "parameter_layout", "pack"]

_KINDS = {"rx": 0, "ry": 1, "rz": 2, "free_flyer": -1}


def __getattr__(name):
    if name == "LAYOUT_VERSION":  # written once, in csrc/pc_plant.h; read from the core (module attribute)
        from postcapture.dynamics.engine import layout_version

        return layout_version()
    raise AttributeError(name)


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
    """The parameter vector of ``system`` at its values."""
    n_inertial = 10 if system.layout.has_target else 0
    return ParameterLayout(tuple(system.parameter_names), system.parameters(), system.spring_k, system.spring_d,
                           n_inertial)


@dataclass(frozen=True)
class Packed:
    """The arrays of :func:`pack` and the facts the Python side needs to read the core's outputs."""

    ints: np.ndarray
    doubles: np.ndarray
    params: ParameterLayout


def _pack_joints(system: System):
    ints, dbl = [], []
    for j, J in enumerate(system.tree.joints):
        ints += [J.parent, _KINDS[J.kind], J.iq, J.iv]
        dbl += list(J.rotation.ravel()) + list(J.translation) + list(system.tree.joints[j].inertia)
    return ints, dbl


def _pack_springs(system: System, plist: ParameterLayout):
    sp = system.assembly.springs
    ints, dbl = [], []
    r = system.n_root_v
    for j, row in enumerate(sp.rows):
        items = sorted(row)
        if len(items) > 2:
            raise ValueError(f"spring {sp.names[j]!r}: at most two coordinates per spring")
        idx = [r + e for e, _ in items] + [-1] * (2 - len(items))
        coef = [c for _, c in items] + [0.0] * (2 - len(items))
        ints += idx + [plist.spring_k[j], plist.spring_d[j]]
        dbl += coef + [sp.k[j], sp.d[j], sp.rest[j]]
    return ints, dbl


def _pack_panels(system: System):
    tree = system.tree
    ints, dbl = [], []
    for p in system.layout.panels:
        root, tip = tree.frame(p.root_frame), tree.frame(p.tip_frame)
        ints += [root.joint, tip.joint, -1 if p.torsion_v is None else int(p.torsion_v)]
        dbl += list(root.rotation.ravel()) + list(root.translation) + list(tip.translation) + [p.length]
    return ints, dbl


def pack(system: System) -> Packed:
    """The int and double arrays of ``system`` for ``pc_model_create`` (see ``csrc/pc_model.c``)."""
    from postcapture.dynamics.engine import layout_version

    layout, tree = system.layout, system.tree
    plist = parameter_layout(system)
    joints_i, joints_d = _pack_joints(system)
    springs_i, springs_d = _pack_springs(system, plist)
    nu = system.n_u
    u_to_v = [-1] * nu
    custom = bool(system.custom_input_matrix)
    if not custom:
        if layout.free_flyer:
            u_to_v[:6] = range(6)
        for i, iv in enumerate(layout.motor_v):
            u_to_v[6 + i] = int(iv)
    prof_i, prof_d, table_t, table_v = pack_profiles(system.inputs.profiles, layout.n_arm)
    panels_i, panels_d = _pack_panels(system)
    r_acc = tree.frame("accelerometer").translation if tree.has_frame("accelerometer") else np.zeros(3)
    target_joint = system.target_joint
    arm_v = [int(i) for i in layout.arm_v]
    header = [
        layout_version(), tree.nq, tree.nv, len(tree.joints), nu, len(system.assembly.springs.rows),
        len(system.inputs.profiles), len(layout.panels), len(table_t), int(custom), layout.n_arm, len(arm_v),
        target_joint, len(plist.names), int(layout.free_flyer),
    ]
    ints = np.array(header + joints_i + springs_i + u_to_v + prof_i + panels_i + arm_v, dtype=np.int32)
    dbl = (
        joints_d + springs_d + (list(np.asarray(system.B, dtype=float).ravel()) if custom else []) + prof_d
        + table_t + table_v + panels_d + list(r_acc) + list(system.target_map.ravel()) + list(system.target_base)
        + list(plist.nominal)
    )
    return Packed(ints, np.asarray(dbl, dtype=float), plist)
