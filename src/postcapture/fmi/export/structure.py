"""The ModelStructure of an exported FMU: which knowns each output and state derivative depends on.

Both model-description writers (FMI 2.0 by variable index, FMI 3.0 by value reference) list these
dependencies for the outputs, the state derivatives and the initial unknowns: a master that builds a
dependency graph (OMSimulator does, at load) then has a few thousand edges instead of "every unknown
depends on every known". The knowns are the states, the parameter inputs and the force inputs (in
initialisation mode too: the states are the variables with ``initial="exact"``); the state correction,
the reset flag and the Jacobian request act only at the next step, and the Jacobian outputs describe the
last step: they depend on no known.

The lists follow the plant's equations (the ones the directional derivatives of ``pc_fmu.c`` differentiate):
the accelerations depend on the joint angles, every velocity, the inputs and the parameters, and on the
root's pose only in an orbit (its gravity gradient: listed, though the directional derivatives leave the
field's partials out, of order n^2); the kinematic outputs depend on the coordinates they read. The sampled
sensors (``gyro_mean_*``, ``accel_mean_*``: means over the last communication step, fixed between
communication points) list what their value before the first step depends on (the rate; the acceleration
less the tidal field): after a step they depend on no known.
"""

from __future__ import annotations

from postcapture.fmi.export.interface import Interface
from postcapture.fmi.export.plant_info import ExportPlant

__all__ = ["dependencies"]


def dependencies(interface: Interface, plant: ExportPlant, *, orbit: bool = False) -> dict[int, list[int]]:
    """Value references of the knowns each unknown depends on (``orbit``: the plant feels a gravity gradient).

    Returns
    -------
    dict of int to list of int
        For every output and state derivative (by value reference), the sorted value references of the
        states and inputs it depends on (empty for the Jacobian outputs and ``jacobian_valid``).
    """
    b = interface.blocks
    x0 = b["x"][0]
    nq, nv = plant.nq, plant.nv

    def q(*idx):  # 0-based configuration entries
        return [x0 + i for i in idx]

    def v(*idx):  # 0-based velocity entries
        return [x0 + nq + i for i in idx]

    def block(name):
        first, count = b[name]
        return list(range(first, first + count))

    joints = q(*range(7, nq))
    accel = joints + v(*range(nv)) + block("u") + block("p")  # what the accelerations depend on
    if orbit:
        accel = q(*range(7)) + accel
    deps: dict[int, list[int]] = {}
    for i in range(nq):  # der(q): dp/dt = R(quat) v_lin, dquat/dt = quat (w, 0) / 2, de/dt = v_e
        if i < 3:
            d = q(3, 4, 5, 6) + v(0, 1, 2)
        elif i < 7:
            d = q(3, 4, 5, 6) + v(3, 4, 5)
        else:
            d = v(i - 1)
        deps[b["dx"][0] + i] = d
    for i in range(nv):
        deps[b["dx"][0] + nq + i] = accel
    arm_v = [int(k) for k in plant.arm_v]
    first_y = b["y"][0]
    for k, signal in enumerate(plant.output_signals()):
        name = signal.name
        if name.startswith("q_BN_"):
            d = q(3, 4, 5, 6)
        elif name.startswith(("omega_BN_B_", "gyro_mean_")):  # a mean: the rate itself before the first step
            d = v(3, 4, 5)
        elif name.startswith("r_BN_N_"):
            d = q(0, 1, 2)
        elif name.startswith("accel_mean_"):  # before the first step: the acceleration less the tidal field
            d = accel  # (in an orbit accel lists the pose, on which the field depends)
        elif name.startswith(("accel_B_", "arm_ddq_")):
            j = int(name.rsplit("_", 1)[1]) - 1 if name.startswith("arm_ddq_") else 0
            d = accel if name.startswith("accel_B_") or j < len(arm_v) else []
        elif name.startswith(("arm_q_", "arm_dq_")):
            j = int(name.rsplit("_", 1)[1]) - 1
            d = [] if j >= len(arm_v) else (q(arm_v[j] + 1) if name.startswith("arm_q_") else v(arm_v[j]))
        else:  # panel tips and torsions: the attitude and the joint angles
            d = q(3, 4, 5, 6) + joints
        deps[first_y + k] = d
    for v_ in interface.variables:
        if v_.block in ("x", "jac", "jvalid"):
            deps[v_.valueReference] = []
    return {k: sorted(set(d)) for k, d in deps.items()}
