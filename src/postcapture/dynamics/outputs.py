"""What the plant outputs at each sample: attitude, rates, accelerations, deflections, momentum, energy.

Every output is a pure function of ``(q, v, t)`` (and the inputs at ``t``). The compiled core computes
the accelerations, the frames, the momenta, the energies and the accelerometer reading
(``csrc/pc_dynamics.c``, ``pc_sample``); :func:`fill_outputs` arranges them, for any number of samples
at once, into named histories with time as the last axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.core.rotations import quat_from_pinocchio
from postcapture.dynamics.system import System

__all__ = ["OutputSpec", "output_specs", "fill_outputs", "OutputRecorder"]


@dataclass(frozen=True)
class OutputSpec:
    """Name, components, unit and meaning of one output."""

    name: str
    components: tuple[str, ...]
    units: str
    long_name: str


def output_specs(system: System) -> list[OutputSpec]:
    """The outputs of a system, in recording order."""
    xyz = ("x", "y", "z")
    n_arm = len(system.layout.arm_v)
    joints = tuple(str(i + 1) for i in range(n_arm))
    specs = [
        OutputSpec("q_BN", ("w", "x", "y", "z"), "1", "chaser attitude quaternion, scalar first, B relative to N"),
        OutputSpec("omega_BN_B", xyz, "rad/s", "chaser body rate, B relative to N, B components"),
        OutputSpec("r_BN_N", xyz, "m", "chaser origin (centre of mass) position in N"),
        OutputSpec("accel_B", xyz, "m/s^2", "chaser linear acceleration at the accelerometer point, B components"),
        OutputSpec("arm_q", joints, "rad", "arm joint angles (link side)"),
        OutputSpec("arm_dq", joints, "rad/s", "arm joint rates"),
        OutputSpec("arm_ddq", joints, "rad/s^2", "arm joint accelerations"),
    ]
    for p in system.layout.panels:
        specs.append(OutputSpec(f"tip_{p.name}", xyz, "m", f"tip deflection of {p.name} in its root frame"))
        specs.append(OutputSpec(f"torsion_{p.name}", ("angle",), "rad", f"root torsion angle of {p.name}"))
    specs += [
        OutputSpec("com_N", xyz, "m", "system centre of mass in N"),
        OutputSpec("momentum_N", xyz, "N s", "total linear momentum, N components"),
        OutputSpec("angular_momentum_N", xyz, "N m s", "total angular momentum about the system centre of mass, N components"),
        OutputSpec("energy_kinetic", ("value",), "J", "kinetic energy"),
        OutputSpec("energy_elastic", ("value",), "J", "elastic energy in the springs"),
        OutputSpec("energy", ("value",), "J", "total mechanical energy (kinetic plus elastic)"),
        OutputSpec("u", tuple(f"u{i}" for i in range(system.n_u)), "N or N m", "known inputs [F_B, tau_B, tau_arm]"),
    ]
    return specs


def fill_outputs(system: System, values: dict, k, q, v, ddq, panels, mech, u) -> None:
    """Write samples ``k`` (an index or a slice) of every output into ``values``.

    ``q`` (nq, n), ``v`` and ``ddq`` (nv, n), ``panels`` (n, npanels, 4: tip deflection, torsion), ``mech``
    (11 + nz, n) and ``u`` (nu, n), as the compiled core returns them.
    """
    off = system.nq - system.nv
    arm = np.asarray(system.layout.arm_v, dtype=int)
    values["q_BN"][:, k] = quat_from_pinocchio(q[3:7])
    values["omega_BN_B"][:, k] = v[3:6]
    values["r_BN_N"][:, k] = q[0:3]
    values["accel_B"][:, k] = mech[11:14]
    if arm.size:
        values["arm_q"][:, k] = q[arm + off]
        values["arm_dq"][:, k] = v[arm]
        values["arm_ddq"][:, k] = ddq[arm]
    for i, p in enumerate(system.layout.panels):
        values[f"tip_{p.name}"][:, k] = panels[:, i, :3].T
        values[f"torsion_{p.name}"][0, k] = panels[:, i, 3]
    values["com_N"][:, k] = mech[0:3]
    values["momentum_N"][:, k] = mech[3:6]
    values["angular_momentum_N"][:, k] = mech[6:9]
    values["energy_kinetic"][0, k] = mech[9]
    values["energy_elastic"][0, k] = mech[10]
    values["energy"][0, k] = mech[9] + mech[10]
    values["u"][:, k] = u


class OutputRecorder:
    """Preallocated output histories for ``n`` samples of a system, filled one sample at a time.

    The truth simulation records a whole run in one call of the compiled core; this serves single
    samples (tests, tools).
    """

    def __init__(self, system: System, n: int, plant=None):
        from postcapture.dynamics.core import CompiledPlant

        self.system = system
        self.plant = plant if plant is not None else CompiledPlant(system)
        self.specs = output_specs(system)
        self.values = {s.name: np.zeros((len(s.components), n)) for s in self.specs}

    def record(self, k: int, q: np.ndarray, v: np.ndarray, t: float) -> np.ndarray:
        """Compute every output at sample ``k``; returns ``ddq``."""
        ddq, panels, mech, u = self.plant.sample(q, v, t)
        fill_outputs(self.system, self.values, slice(k, k + 1), np.asarray(q, float)[:, None],
                     np.asarray(v, float)[:, None], ddq[:, None], panels[None], mech[:, None], u[:, None])
        return ddq
