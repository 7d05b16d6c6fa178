"""Pack a :class:`~postcapture.dynamics.system.System` into the compiled core's int and double arrays.

The layout is described in ``csrc/pc_model.c``. The same arrays are embedded in exported FMUs, so the
native core and an FMU are built from one description. Also defined here: the plant's named parameter
vector ``p`` (see :func:`parameter_layout`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from postcapture.config.excitation import Chirp, Sine, Step, Table, channel_index
from postcapture.dynamics.system import System

__all__ = ["LAYOUT_VERSION", "Packed", "pack_profiles", "ParameterLayout", "parameter_layout", "pack", "target_parameter_map"]

LAYOUT_VERSION = 3
_KINDS = {"JointModelRX": 0, "JointModelRY": 1, "JointModelRZ": 2, "JointModelFreeFlyer": -1}
_INERTIA_NAMES = ("m", "mc_x", "mc_y", "mc_z", "I_xx", "I_xy", "I_yy", "I_xz", "I_yz", "I_zz")


@dataclass(frozen=True)
class ParameterLayout:
    """The named parameter vector of a system and how each spring depends on it.

    ``names`` and ``nominal`` in order: the target hub's ten inertial parameters in the nominal target
    frame T (Pinocchio's dynamic-parameter order; kg, kg m, kg m^2 about T's origin), then for each panel
    (chaser panels, then target panels) ``<panel>.bending_scale``, ``<panel>.torsion_scale``,
    ``<panel>.damping_scale``, then ``arm.stiffness_scale`` and ``arm.damping_scale`` (dimensionless,
    nominal 1). ``spring_k[j]`` / ``spring_d[j]``: index of the parameter scaling spring j's stiffness /
    damping (-1: none; the Spong servos are not scaled).
    """

    names: tuple[str, ...]
    nominal: np.ndarray
    spring_k: tuple[int, ...]
    spring_d: tuple[int, ...]
    n_inertial: int


def parameter_layout(system: System) -> ParameterLayout:
    """The parameter vector of ``system`` at its current values (see :class:`ParameterLayout`)."""
    names: list[str] = []
    nominal: list[float] = []
    layout = system.layout
    n_inertial = 0
    if layout.has_target and layout.target_hub is not None:
        hub = layout.target_hub
        m_hub = system.target_mass - layout.target_panel_mass  # the current mass (a filter may have changed it)
        pi = pin.Inertia(m_hub, hub.com, hub.inertia).toDynamicParameters()
        names += [f"target.{n}" for n in _INERTIA_NAMES]
        nominal += [float(x) for x in pi]
        n_inertial = 10
    panel_index = {}
    for p in layout.panels:
        panel_index[p.name] = len(names)
        names += [f"{p.name}.bending_scale", f"{p.name}.torsion_scale", f"{p.name}.damping_scale"]
        nominal += [1.0, 1.0, 1.0]
    arm_index = None
    if layout.n_arm and layout.arm_v:
        arm_index = len(names)
        names += ["arm.stiffness_scale", "arm.damping_scale"]
        nominal += [1.0, 1.0]
    spring_k, spring_d = [], []
    for name in system.assembly.springs.names:
        k = d = -1
        for pname, base in panel_index.items():
            if name == f"{pname}_torsion":
                k, d = base + 1, base + 2
            elif name.startswith(f"{pname}_bend_"):
                k, d = base, base + 2
        if arm_index is not None and name.startswith("arm_") and not name.endswith("_servo"):
            k, d = arm_index, arm_index + 1
        spring_k.append(k)
        spring_d.append(d)
    return ParameterLayout(tuple(names), np.asarray(nominal, dtype=float), tuple(spring_k), tuple(spring_d), n_inertial)


def _skew(a) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _sym(I) -> np.ndarray:
    return np.array([I[0, 0], I[0, 1], I[1, 1], I[0, 2], I[1, 2], I[2, 2]])


def target_parameter_map(X: pin.SE3) -> np.ndarray:
    """The 10 x 10 linear map from dynamic parameters in frame T to those in the joint frame J.

    With T placed at ``X = (R, p)`` in J: ``m' = m``, ``h' = R h + m p`` and, about J's origin,
    ``I' = R I R^T - [R h]x [p]x - [p]x [R h]x - m [p]x^2`` (linear in ``(m, h, I)``).
    """
    R, p = X.rotation, X.translation
    L = np.zeros((10, 10))
    P = _skew(p)
    for k in range(10):
        e = np.zeros(10)
        e[k] = 1.0
        m, h = e[0], e[1:4]
        I = np.array([[e[4], e[5], e[7]], [e[5], e[6], e[8]], [e[7], e[8], e[9]]])
        Rh = R @ h
        out = np.concatenate([[m], Rh + m * p, _sym(R @ I @ R.T - _skew(Rh) @ P - P @ _skew(Rh) - m * P @ P)])
        L[:, k] = out
    return L


@dataclass(frozen=True)
class Packed:
    """The arrays of :func:`pack` and the facts the Python side needs to read the core's outputs."""

    ints: np.ndarray
    doubles: np.ndarray
    params: ParameterLayout
    frames: tuple[str, ...]


def pack_profiles(profiles, n_arm: int):
    """Per profile: ints ``(kind, channel, table offset, table length)`` and doubles ``(start, stop, a,
    rise, w, phase, offset, f0, rate)``, then the concatenated table times and values."""
    ints, dbl, table_t, table_v = [], [], [], []
    for p in profiles:
        stop = math.inf if p.stop is None else p.stop
        start = p.start
        a = rise = w = phase = offset = f0 = rate = 0.0
        table = n_table = 0
        if isinstance(p, Step):
            kind, a, rise = 0, p.amplitude, p.rise_time
        elif isinstance(p, Sine):
            kind, a, w, phase, offset = 1, p.amplitude, 2 * math.pi * p.frequency, p.phase, p.offset
        elif isinstance(p, Chirp):
            kind, a, f0, phase = 2, p.amplitude, p.f0, p.phase
            rate = (p.f1 - p.f0) / (stop - start)
        elif isinstance(p, Table):
            kind, table, n_table = 3, len(table_t), len(p.t)
            table_t += list(p.t)
            table_v += list(p.value)
        else:
            raise TypeError(f"unknown excitation profile {type(p).__name__}")
        ints += [kind, channel_index(p.channel, n_arm), table, n_table]
        dbl += [start, stop, a, rise, w, phase, offset, f0, rate]
    return ints, dbl, table_t, table_v


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
    frames, frames_i, frames_d = [], [], []
    for p in layout.panels:
        for name in (p.root_frame, p.tip_frame):
            f = model.frames[model.getFrameId(name)]
            frames.append(name)
            frames_i.append(int(f.parentJoint) - 1)
            frames_d += list(f.placement.rotation.ravel()) + list(f.placement.translation)
    r_acc = np.zeros(3)
    if model.existFrame("accelerometer"):
        r_acc = model.frames[model.getFrameId("accelerometer")].placement.translation.copy()
    t_L = np.zeros((10, 10))
    t_base = np.zeros(10)
    target_joint = -1
    if plist.n_inertial:
        frame = model.frames[model.getFrameId("target")]
        target_joint = int(frame.parentJoint)
        t_L = target_parameter_map(frame.placement)
        t_base = model.inertias[target_joint].toDynamicParameters() - t_L @ plist.nominal[:10]
        target_joint -= 1
    arm_v = [int(i) for i in layout.arm_v]
    header = [
        LAYOUT_VERSION, model.nq, model.nv, nj, nu, len(sp.rows), len(system.inputs.profiles), len(frames),
        len(table_t), int(custom), layout.n_arm, len(arm_v), target_joint, len(plist.names), int(layout.free_flyer),
    ]
    ints = np.array(header + joints_i + springs_i + u_to_v + prof_i + frames_i + arm_v, dtype=np.int32)
    dbl = (
        joints_d + springs_d + (list(np.asarray(system.B, dtype=float).ravel()) if custom else []) + prof_d
        + table_t + table_v + frames_d + list(r_acc) + list(t_L.ravel()) + list(t_base) + list(plist.nominal)
    )
    return Packed(ints, np.asarray(dbl, dtype=float), plist, tuple(frames))
