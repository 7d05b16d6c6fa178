"""What an exported FMU needs to know about a plant: sizes, coordinates, parameters and named outputs.

The plant itself runs in the compiled core (``dynamics/csrc``) inside the FMU; this only describes it
for the variable table, the model description and the generated data header.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.dynamics.packing import Packed, pack
from postcapture.dynamics.system import System

__all__ = ["Parameter", "OutputSignal", "ExportPlant"]

_KIND = {"free_flyer": -1, "rx": 0, "ry": 1, "rz": 2}


@dataclass(frozen=True)
class Parameter:
    """One tunable parameter of the FMU."""

    name: str
    value: float
    unit: str
    description: str
    min: float | None = None


@dataclass(frozen=True)
class OutputSignal:
    """One named scalar output."""

    name: str
    unit: str
    description: str
    variability: str = "continuous"


def _parameter_unit(name: str) -> tuple[str, str]:
    field = name.split(".", 1)[1]
    if field == "m":
        return "kg", "target hub mass (nominal frame T)"
    if field.startswith("mc_"):
        return "kg.m", f"target hub first moment of mass, {field[3:]} (nominal frame T)"
    if field.startswith("I_"):
        return "kg.m2", f"target hub inertia {field[2:]} about T's origin"
    return "1", f"{name.replace('_', ' ')} (factor, nominal 1)"


class ExportPlant:
    """A built system as the FMU export sees it.

    Parameters
    ----------
    system : System
        A system from :func:`postcapture.dynamics.build.build_system`; its current parameters become the
        FMU's defaults.
    """

    def __init__(self, system: System):
        tree = system.tree
        layout = system.layout
        if not layout.free_flyer:
            raise ValueError("the FMU export needs a free-flyer chaser")
        self.system = system
        self.tree = tree
        self.layout = layout
        self.packed: Packed = pack(system)
        self.nq, self.nv, self.n_u = tree.nq, tree.nv, system.n_u
        self.nx = self.nq + self.nv
        self.n_arm = layout.n_arm
        self.arm_v = np.asarray(layout.arm_v, dtype=int)
        self.has_target = layout.has_target
        self.free_flyer = True
        self.joints = [(J.name, J.parent, _KIND[J.kind], J.iq, J.iv, J.rotation.copy(), J.translation.copy())
                       for J in tree.joints]
        params = []
        for name, value in zip(system.parameter_names, system.parameters(), strict=True):
            unit, what = _parameter_unit(name)
            lo = 0.0 if unit == "1" or name == "target.m" else None
            params.append(Parameter(name, float(value), unit, what, min=lo))
        self.parameters = params  # the parameter vector (dynamics.parameters), in its order
        self.target_panel_mass = float(layout.target_panel_mass) if self.has_target else 0.0
        self.accelerometer_position = tuple(float(c) for c in system.scenario.chaser.accelerometer_position)

    def output_signals(self) -> list[OutputSignal]:
        """Names, units and meanings of the named outputs, in the FMU's order."""
        xyz = ("x", "y", "z")
        sig = [OutputSignal(f"q_BN_{c}", "1", f"chaser attitude quaternion q_BN, component {c} (scalar first, w >= 0)")
               for c in ("w", "x", "y", "z")]
        sig += [OutputSignal(f"omega_BN_B_{c}", "rad/s", f"chaser body rate, B relative to N, B component {c}") for c in xyz]
        sig += [OutputSignal(f"r_BN_N_{c}", "m", f"chaser origin position in N, component {c}") for c in xyz]
        sig += [OutputSignal(f"accel_B_{c}", "m/s2", f"chaser acceleration at the accelerometer point, B component {c}")
                for c in xyz]
        for label, unit, what in (("arm_q", "rad", "angle"), ("arm_dq", "rad/s", "rate"), ("arm_ddq", "rad/s2", "acceleration")):
            sig += [OutputSignal(f"{label}_{i + 1}", unit, f"arm joint {i + 1} {what} (link side; zero when locked)")
                    for i in range(self.n_arm)]
        for p in self.layout.panels:
            sig += [OutputSignal(f"tip_{p.name}_{c}", "m", f"tip deflection of {p.name} in its root frame, component {c}")
                    for c in xyz]
            sig.append(OutputSignal(f"torsion_{p.name}", "rad", f"root torsion angle of {p.name}"))
        # the sampled inertial sensors (noise-free): means over the last communication step, constant between
        # communication points (discrete); before the first step the instantaneous values (pc_fmu.c)
        sig += [OutputSignal(f"gyro_mean_{c}", "rad/s", "gyro: mean body rate over the last communication step, "
                             "box_minus(q_end, q_start) / step, B at its start, component " + c, "discrete")
                for c in xyz]
        sig += [OutputSignal(f"accel_mean_{c}", "m/s2", "accelerometer: mean specific force at its point over the "
                             "last communication step (velocity increment in B at its start / step, less the "
                             "orbit's tidal field), component " + c, "discrete") for c in xyz]
        return sig
