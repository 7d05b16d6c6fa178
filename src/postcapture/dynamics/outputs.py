"""What the plant outputs at each sample: attitude, rates, accelerations, deflections, momentum, energy.

Every output is a pure function of ``(q, v, t)`` (and the inputs at ``t``); :class:`OutputRecorder`
computes them into preallocated arrays with time as the last axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from postcapture.core.rotations import cross3
from postcapture.dynamics.system import System

__all__ = ["OutputSpec", "output_specs", "accelerometer_reading", "OutputRecorder"]


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


def accelerometer_reading(v: np.ndarray, ddq: np.ndarray, r_B: np.ndarray) -> np.ndarray:
    """Acceleration of a point of the chaser at ``r_B`` (B components), from the root's twist rates.

    ``a = dv/dt + w x v + dw/dt x r + w x (w x r)``, with Pinocchio's body-frame ``v = (v, w)``.
    Without gravity this is also the specific force an accelerometer senses.
    """
    w = v[3:6]
    return ddq[:3] + cross3(w, v[:3]) + cross3(ddq[3:6], r_B) + cross3(w, cross3(w, r_B))


class OutputRecorder:
    """Preallocated output histories for ``n`` samples of a system."""

    def __init__(self, system: System, n: int):
        self.system = system
        self.specs = output_specs(system)
        self.values = {s.name: np.zeros((len(s.components), n)) for s in self.specs}
        model = system.model
        self._acc_r = model.frames[model.getFrameId("accelerometer")].placement.translation.copy()
        self._panels = [
            (p, model.getFrameId(p.root_frame), model.getFrameId(p.tip_frame)) for p in system.layout.panels
        ]
        self._arm = np.asarray(system.layout.arm_v, dtype=int)

    def record(self, k: int, q: np.ndarray, v: np.ndarray, t: float) -> np.ndarray:
        """Compute every output at sample ``k``; returns ``ddq``.

        One forward-kinematics pass (inside ``centerOfMass``) serves the frames, the momentum and the
        kinetic energy.
        """
        sysm = self.system
        model, data = sysm.model, sysm.data
        val = self.values
        u = sysm.inputs(t)
        ddq = sysm.acceleration_tau(q, v, sysm.input_torque(u))
        quat = val["q_BN"]
        sign = -1.0 if q[6] < 0.0 else 1.0  # w >= 0 on output; Pinocchio stores (x, y, z, w)
        quat[0, k], quat[1, k], quat[2, k], quat[3, k] = sign * q[6], sign * q[3], sign * q[4], sign * q[5]
        val["omega_BN_B"][:, k] = v[3:6]
        val["r_BN_N"][:, k] = q[:3]
        val["accel_B"][:, k] = accelerometer_reading(v, ddq, self._acc_r)
        if self._arm.size:
            val["arm_q"][:, k] = q[self._arm + 1]
            val["arm_dq"][:, k] = v[self._arm]
            val["arm_ddq"][:, k] = ddq[self._arm]
        val["com_N"][:, k] = pin.centerOfMass(model, data, q, v)
        for p, f_root, f_tip in self._panels:
            root = pin.updateFramePlacement(model, data, f_root)
            tip = root.actInv(pin.updateFramePlacement(model, data, f_tip).translation)
            tip[0] -= p.length
            val[f"tip_{p.name}"][:, k] = tip
            val[f"torsion_{p.name}"][0, k] = q[p.torsion_v + 1] if p.torsion_v is not None else 0.0
        hg = pin.computeCentroidalMomentum(model, data)
        val["momentum_N"][:, k] = hg.linear
        val["angular_momentum_N"][:, k] = hg.angular
        ke = pin.computeKineticEnergy(model, data)
        pe = sysm.elastic_energy(q)
        val["energy_kinetic"][0, k] = ke
        val["energy_elastic"][0, k] = pe
        val["energy"][0, k] = ke + pe
        val["u"][:, k] = u
        return ddq
