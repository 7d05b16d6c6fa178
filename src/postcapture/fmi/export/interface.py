"""The exported FMU's variables: names, value references, causalities, units and start values.

One table serves both model-description writers (FMI 2.0 and 3.0), the C header (value-reference
ranges) and the mapping file. Value references are consecutive, in this order:

==========================  ==========  ============================================================
block                       causality   meaning
==========================  ==========  ============================================================
``q[i]``, ``v[i]``          output      the state ``x = [q, v]`` (continuous states, ``initial="exact"``)
``der(q[i])``, ...          local       ambient state derivatives (ModelStructure: the derivatives)
named outputs               output      ``q_BN_w`` ... ``accel_B_x`` ... ``arm_ddq_7``, tips, torsions,
                                        then the sampled sensors ``gyro_mean_x`` ... ``accel_mean_z``
                                        (discrete: means over the last communication step)
``target.m`` ... ``arm.*``  input       the plant's parameter vector, held constant: inputs, so that
                                        their partials are standard directional derivatives
``force_x`` ... ``joint_n`` input       added to the embedded excitation, held over a step
``x_corr[i]``               input       the state correction (applied when ``reset > 0.5``)
``reset``                   input       replace the state by ``x_corr`` at the start of a step
``jacobian_request``        input       compute ``F``, ``G``, ``H``, ``Hp`` during the next step
``F[i,j]``, ``G[i,k]``,     output      the exact step and measurement Jacobians of the last step
``H[i,j]``, ``Hp[i,k]``                 (discrete; 0 unless requested)
``jacobian_valid``          output      1 when ``F``, ``G``, ``H``, ``Hp`` describe the last step, else 0
``time``                    independent FMI 3.0 only: the independent variable
==========================  ==========  ============================================================
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from postcapture.config.excitation import CHASER_CHANNELS
from postcapture.fmi.export.plant_info import ExportPlant

__all__ = ["ScalarVariable", "Interface", "build_interface", "UNITS"]

# unit name -> SI base-unit exponents (FMI 2.0 BaseUnit attributes)
UNITS = {
    "1": {},
    "m": {"m": 1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "1/s": {"s": -1},
    "s": {"s": 1},
    "kg": {"kg": 1},
    "kg.m": {"kg": 1, "m": 1},
    "kg.m2": {"kg": 1, "m": 2},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "N.m/rad": {"kg": 1, "m": 2, "s": -2, "rad": -1},
    "N.m.s/rad": {"kg": 1, "m": 2, "s": -1, "rad": -1},
}


@dataclass(frozen=True)
class ScalarVariable:
    """One FMI scalar variable; attribute names follow the FMI specification."""

    name: str
    valueReference: int
    causality: str
    variability: str
    initial: str | None
    description: str
    unit: str | None = None
    start: float | None = None
    derivative: int | None = None  # 1-based index of the state this variable is the derivative of
    block: str = ""  # "x", "dx", "y", "p", "u", "xc", "reset", "jreq", "jac", "jvalid", "time"


@dataclass
class Interface:
    """The variable table of an exported FMU and the index ranges of its blocks."""

    variables: list[ScalarVariable]
    blocks: dict[str, tuple[int, int]] = field(default_factory=dict)  # block -> (first vr, count)
    nx: int = 0
    nt: int = 0
    nz: int = 0
    step_jacobian: bool = False

    def names(self, block: str) -> list[str]:
        """Names of one block's variables, in value-reference order."""
        first, count = self.blocks[block]
        return [v.name for v in self.variables[first : first + count]]


def _coordinate_labels(plant: ExportPlant):
    """Description and units of each configuration and velocity coordinate."""
    q_lab, q_unit, v_lab, v_unit = [""] * plant.nq, [""] * plant.nq, [""] * plant.nv, [""] * plant.nv
    for name, _parent, kind, iq, iv, _R, _p in plant.joints:
        if kind < 0:
            for k, c in enumerate("xyz"):
                q_lab[iq + k], q_unit[iq + k] = f"{name}: position {c} in N", "m"
                v_lab[iv + k], v_unit[iv + k] = f"{name}: linear velocity {c}, body frame", "m/s"
                v_lab[iv + 3 + k], v_unit[iv + 3 + k] = f"{name}: angular velocity {c}, body frame", "rad/s"
            for k, c in enumerate("xyzw"):
                q_lab[iq + 3 + k], q_unit[iq + 3 + k] = (
                    f"{name}: attitude quaternion {c} (Pinocchio order x, y, z, w)",
                    "1",
                )
        else:
            q_lab[iq], q_unit[iq] = f"{name}: joint angle", "rad"
            v_lab[iv], v_unit[iv] = f"{name}: joint rate", "rad/s"
    return q_lab, q_unit, v_lab, v_unit


_DER_UNIT = {"m": "m/s", "1": "1/s", "rad": "rad/s", "m/s": "m/s2", "rad/s": "rad/s2"}


class _Table:
    """The variables in value-reference order and each block's range."""

    def __init__(self):
        self.variables: list[ScalarVariable] = []
        self.blocks: dict[str, tuple[int, int]] = {}

    def block(self, name: str, rows: list[dict]) -> None:
        first = len(self.variables)
        for kw in rows:
            self.variables.append(ScalarVariable(valueReference=len(self.variables), block=name, **kw))
        self.blocks[name] = (first, len(self.variables) - first)


def _state_blocks(t: _Table, plant: ExportPlant, x0: np.ndarray, x_names: list[str]) -> list[str]:
    """States, their derivatives and the named outputs; returns the states' units."""
    q_lab, q_unit, v_lab, v_unit = _coordinate_labels(plant)
    x_labels, x_units = q_lab + v_lab, q_unit + v_unit
    t.block("x", [dict(name=name, causality="output", variability="continuous", initial="exact",
                       description=f"state: {x_labels[i]}", unit=x_units[i], start=float(x0[i]))
                  for i, name in enumerate(x_names)])
    t.block("dx", [dict(name=f"der({name})", causality="local", variability="continuous", initial="calculated",
                        description=f"time derivative of {name}", unit=_DER_UNIT[x_units[i]], derivative=i + 1)
                   for i, name in enumerate(x_names)])
    t.block("y", [dict(name=s.name, causality="output", variability=s.variability, initial="calculated",
                       description=s.description, unit=s.unit) for s in plant.output_signals()])
    return x_units


def _input_blocks(t: _Table, plant: ExportPlant, x0: np.ndarray, x_names: list[str], x_units: list[str]) -> None:
    """The parameter inputs, the force inputs, the state correction, the reset flag and the Jacobian request."""
    t.block("p", [dict(name=p.name, causality="input", variability="continuous", initial=None,
                       description=f"{p.description}; an input held constant (its partials are directional "
                                   "derivatives)", unit=p.unit, start=p.value) for p in plant.parameters])
    channels = list(CHASER_CHANNELS) + [f"joint_{i + 1}" for i in range(plant.n_arm)]
    units = ["N"] * 3 + ["N.m"] * 3 + ["N.m"] * plant.n_arm
    t.block("u", [dict(name=ch, causality="input", variability="continuous", initial=None,
                       description=f"{ch}: added to the embedded excitation, held over a communication step",
                       unit=unit, start=0.0) for ch, unit in zip(channels, units, strict=True)])
    t.block("xc", [dict(name=f"x_corr[{i + 1}]", causality="input", variability="discrete", initial=None,
                        description=f"correction of {name}: replaces it at the start of the next step when reset > 0.5",
                        unit=x_units[i], start=float(x0[i])) for i, name in enumerate(x_names)])
    t.block("reset", [dict(name="reset", causality="input", variability="discrete", initial=None, start=0.0,
                           description="when > 0.5 at the start of a step, the state is replaced by x_corr",
                           unit="1")])
    t.block("jreq", [dict(name="jacobian_request", causality="input", variability="discrete", initial=None, start=0.0,
                          description="when > 0.5, the next step also computes the outputs F, G, H, Hp", unit="1")])


def _jacobian_block(t: _Table, nt: int, n_z: int, n_p: int) -> None:
    """Discrete outputs ``F[i,j]``, ``G[i,k]``, ``H[i,j]``, ``Hp[i,k]`` row by row, and ``jacobian_valid``."""
    rows = []
    for symbol, n_rows, cols, description in (
        ("F", nt, nt, "step Jacobian d x_k+1 / d x_k (tangent coordinates)"),
        ("G", nt, n_p, "step Jacobian d x_k+1 / d p (tangent coordinates; p the parameter inputs)"),
        ("H", n_z, nt, "measurement Jacobian d z_k+1 / d x_k+1 (tangent coordinates)"),
        ("Hp", n_z, n_p, "measurement Jacobian d z_k+1 / d p at fixed state"),
    ):
        for i in range(n_rows):
            for j in range(cols):
                rows.append(dict(name=f"{symbol}[{i + 1},{j + 1}]", causality="output", variability="discrete",
                                 initial="calculated", description=description + "; 0 unless requested"))
    t.block("jac", rows)
    t.block("jvalid", [dict(name="jacobian_valid", causality="output", variability="discrete", initial="calculated",
                            description="1 when F, G, H, Hp describe the last step (it was requested), else 0",
                            unit="1")])


def build_interface(
    plant: ExportPlant, x0: np.ndarray, *, step_jacobian: bool, n_y: int, n_z: int, independent_time: bool = False
) -> Interface:
    """The variable table of an FMU of ``plant`` starting at ``x0`` (nx,); ``independent_time`` adds the
    independent variable ``time`` (last; FMI 3.0 requires one)."""
    if len(plant.output_signals()) != n_y:
        raise RuntimeError(f"output table has {len(plant.output_signals())} entries, generated code {n_y}")
    t = _Table()
    x_names = [f"q[{i + 1}]" for i in range(plant.nq)] + [f"v[{i + 1}]" for i in range(plant.nv)]
    x_units = _state_blocks(t, plant, x0, x_names)
    _input_blocks(t, plant, x0, x_names, x_units)
    nt = 2 * plant.nv
    if step_jacobian:
        _jacobian_block(t, nt, n_z, len(plant.parameters))
    if independent_time:
        t.block("time", [dict(name="time", causality="independent", variability="continuous", initial=None,
                              description="simulation time", unit="s")])
    return Interface(t.variables, t.blocks, nx=plant.nx, nt=nt, nz=n_z, step_jacobian=step_jacobian)
