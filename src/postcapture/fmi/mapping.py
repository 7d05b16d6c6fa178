"""The mapping file: which variables of an FMU's ``modelDescription.xml`` a filter uses.

A mapping names, by their FMI variable names, the state vector and its kinematics, the attitude and
body rate inside it (and, for the filters that read the inertial sensors' increments and the encoders,
the chaser's linear velocity and the arm's joint angles), the measurement (chaser acceleration, arm joint
accelerations) and where the accelerometer sits, the target-mass variable or the inputs that hold the
plant's parameter vector, how the state is corrected (inputs plus a reset flag) and, optionally,
exported Jacobian outputs. It is a small TOML file; :func:`postcapture.fmi.export_fmu` writes one for its FMUs (inside
the FMU under ``resources/postcapture_mapping.toml`` and next to it as ``<name>.mapping.toml``).

A mapping is checked twice: on its own when read (every entry present and of the right kind, no
variable used twice, attitude and rates fitting the kinematics), and against the FMU's variables
(:func:`check_mapping`: every name exists, corrections, the reset flag and the parameter vector are real
inputs, the mass a tunable parameter or an input, the state and measurements readable outputs). Each
problem is listed.

An example (the mapping of an exported plant, shortened):

.. code-block:: toml

    format = 1

    [state]
    variables = ["q[1]", "q[2]", "...", "v[25]"]   # x, in order
    kinematics = "free_flyer"   # or "quaternion"
    attitude = ["q[7]", "q[4]", "q[5]", "q[6]"]     # q_BN (w, x, y, z), entries of x
    rate = ["v[4]", "v[5]", "v[6]"]                 # omega_BN_B (rad/s), entries of x
    velocity = ["v[1]", "v[2]", "v[3]"]             # optional: v_B of the chaser's origin (m/s), entries of x
    arm = ["q[14]", "...", "q[20]"]                 # optional: the arm's joint angles (rad), entries of x

    [correction]
    inputs = ["x_corr[1]", "...", "x_corr[51]"]    # same order as state.variables
    reset = "reset"                                 # > 0.5 at fmi2DoStep: the state becomes the inputs

    [measurement]
    accel = ["accel_B_x", "accel_B_y", "accel_B_z"] # m/s2, B frame
    joint_accel = ["arm_ddq_1", "...", "arm_ddq_7"] # rad/s2
    accelerometer_position = [0.0, 0.0, 0.3]        # optional: the accelerometer in B (m)

    [parameters]                                    # optional
    inputs = ["target.m", "...", "arm.damping_scale"]  # inputs holding the plant's parameter vector
    mass_offset = 350.0                             # kg: the target's mass is target.m plus this
    # names = [...]   postcapture's names of the inputs (default: their own names)
    # mass = "m_target"   or a variable that is the target's mass (a tunable parameter or an input)

    [jacobians]                                     # optional: exact step Jacobians as outputs
    request = "jacobian_request"
    F = "F[{i},{j}]"                                # d x_k+1 / d x_k (tangent)
    H = "H[{i},{j}]"                                # d z_k+1 / d x_k+1
    G = "G[{i},{j}]"                                # d x_k+1 / d p, columns in [parameters] inputs' order
    Hp = "Hp[{i},{j}]"                              # d z_k+1 / d p
    valid = "jacobian_valid"                        # 1 when they describe the last step
    # g = "g[{i}]" and h = "h[{i}]": d x_k+1 / d m and d z_k+1 / d m for a mass variable

Kinematics: ``free_flyer`` is a Pinocchio free-flyer state ``x = [q (nq), v (nq - 1)]`` (position,
quaternion x y z w, joint angles; body twist, joint rates) with right-perturbation tangents;
``quaternion`` is any state holding a unit quaternion ``q_BN`` (the ``attitude`` entries): its tangent
puts the body-frame attitude error first, then every other entry of ``x`` in order. For ``free_flyer``
the chaser's linear velocity is ``v[1..3]`` (the body twist); ``quaternion`` states name it.

The target's mass, for the filters that estimate it alone, is either a variable (``mass``) or, with a
parameter vector whose names are postcapture's (:mod:`postcapture.dynamics.parameters`), ``target.m``
plus ``mass_offset``, changed at a fixed centre of mass and inertia about it (as the native model does).
"""

from __future__ import annotations

import difflib
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field

from postcapture.config.names import INTEGRATORS
from postcapture.config.types import Frozen, quantity
from postcapture.core.errors import FMIError
from postcapture.fmi.kinematics import layout_problems

__all__ = ["KINEMATICS", "JacobianOutputs", "Mapping", "MappingFile", "load_mapping", "check_mapping",
           "mapping_sidecar"]

KINEMATICS = ("free_flyer", "quaternion")


_MATRICES = ("F", "H", "G", "Hp")
_COLUMNS = ("g", "h")


@dataclass(frozen=True)
class JacobianOutputs:
    """Names of exported Jacobian outputs: patterns with ``{i}`` and ``{j}`` (1-based).

    ``F`` (n x n) and ``H`` (m x n) always; ``g`` (n) and ``h`` (m), the derivatives with respect to a mass
    variable, and ``G`` (n x n_p) and ``Hp`` (m x n_p), those with respect to the parameter inputs, when
    the FMU has them; ``valid`` an output that is 1 when they describe the last step.
    """

    request: str
    F: str
    H: str
    g: str | None = None
    h: str | None = None
    G: str | None = None
    Hp: str | None = None
    valid: str | None = None

    def expand(self, n: int, m: int, n_p: int = 0) -> dict[str, list[str]]:
        """Every name of the patterns given: ``F`` (n x n, row-major), ``H`` (m x n), ``g`` (n), ``h`` (m),
        ``G`` (n x n_p), ``Hp`` (m x n_p)."""
        rows = {"F": (n, n), "H": (m, n), "G": (n, n_p), "Hp": (m, n_p), "g": (n, None), "h": (m, None)}
        out = {}
        for key, (r, c) in rows.items():
            pattern = getattr(self, key)
            if pattern is None:
                continue
            out[key] = ([pattern.format(i=i + 1, j=j + 1) for i in range(r) for j in range(c)] if c is not None
                        else [pattern.format(i=i + 1) for i in range(r)])
        return out


def _pattern_problems(jac: JacobianOutputs) -> list[str]:
    """Jacobian name patterns must give one distinct name per entry: ``{i}`` (and ``{j}`` for matrices)."""
    problems = []
    for key, fields in [(k, ("i", "j")) for k in _MATRICES] + [(k, ("i",)) for k in _COLUMNS]:
        pattern = getattr(jac, key)
        if pattern is None:
            continue
        try:
            a = pattern.format(i=1, j=2)
            b = pattern.format(i=2, j=1)
        except (KeyError, IndexError, ValueError, AttributeError) as exc:
            problems.append(f"[jacobians] {key}: {pattern!r} is not a name pattern with {{i}}"
                            f"{' and {j}' if len(fields) == 2 else ''} ({type(exc).__name__}: {exc})")
            continue
        if any("{" + f + "}" not in pattern for f in fields) or a == b:
            need = " and ".join("{" + f + "}" for f in fields)
            problems.append(f"[jacobians] {key}: expected a pattern holding {need}, found {pattern!r}")
    return problems


def _duplicates(names) -> list[str]:
    """The names that occur more than once, in order of their second occurrence."""
    seen, dup = set(), []
    for n in names:
        if n in seen and n not in dup:
            dup.append(n)
        seen.add(n)
    return dup


def _overlap_problems(state, corr, reset, attitude, rate, accel, joint, mass, inputs=()) -> list[str]:
    """A variable may play one role only (the attitude and rates are state entries by design)."""
    problems = []
    for key, names in (("[state] variables", state), ("[correction] inputs", corr), ("[state] attitude", attitude),
                       ("[state] rate", rate), ("[measurement] accel", accel), ("[measurement] joint_accel", joint),
                       ("[parameters] inputs", inputs)):
        dup = _duplicates(names or ())
        if dup:
            problems.append(f"{key}: {', '.join(repr(d) for d in dup)} listed more than once")
    shared = sorted(set(attitude or ()) & set(rate or ()))
    if shared:
        problems.append(f"[state] rate: {', '.join(repr(n) for n in shared)} also in [state] attitude: "
                        "the attitude and rate entries must not overlap")
    roles = {"state.variables": set(state or ()), "correction.inputs": set(corr or ()),
             "correction.reset": {reset} if reset else set(), "parameters.mass": {mass} if mass else set(),
             "parameters.inputs": set(inputs or ())}
    keys = list(roles)
    for a in range(len(keys)):
        for b in range(a + 1, len(keys)):
            both = sorted(roles[keys[a]] & roles[keys[b]])
            if both:
                problems.append(f"{keys[b]}: {', '.join(repr(n) for n in both)} also in {keys[a]}: "
                                "a variable plays one role only")
    return problems


# ------------------------------------------------------------------------------------------ the file's schema
VarName = Annotated[str, Field(min_length=1, max_length=512, pattern=r"^[^\x00-\x1f\x7f]+$")]
"""An FMI variable name: any printable text (FMI allows brackets, dots and spaces), at most 512 characters."""
_GUID = r"^\{?[0-9A-Fa-f]{8}-[0-9A-Fa-f]{4}-[0-9A-Fa-f]{4}-[0-9A-Fa-f]{4}-[0-9A-Fa-f]{12}\}?$"


def _names(n: int):
    return Annotated[tuple[VarName, ...], Field(min_length=n, max_length=n)]


class _StateSection(Frozen):
    variables: tuple[VarName, ...] = Field(min_length=1, max_length=100_000)
    kinematics: Literal[KINEMATICS]
    attitude: _names(4)
    rate: _names(3)
    velocity: _names(3) | None = None
    arm: tuple[VarName, ...] | None = Field(default=None, max_length=1000)


class _CorrectionSection(Frozen):
    inputs: tuple[VarName, ...] = Field(max_length=100_000)
    reset: VarName


class _MeasurementSection(Frozen):
    accel: _names(3)
    joint_accel: tuple[VarName, ...] = Field(default=(), max_length=1000)
    accelerometer_position: Annotated[tuple[quantity("m", ge=-1e4, le=1e4), ...],
                                      Field(min_length=3, max_length=3)] | None = None


class _ParametersSection(Frozen):
    mass: VarName | None = None
    inputs: tuple[VarName, ...] | None = Field(default=None, min_length=1, max_length=10_000)
    names: tuple[VarName, ...] | None = Field(default=None, min_length=1, max_length=10_000)
    mass_offset: quantity("kg", ge=0.0, le=1e9) | None = None


class _JacobianSection(Frozen):
    request: VarName
    F: VarName
    H: VarName
    g: VarName | None = None
    h: VarName | None = None
    G: VarName | None = None
    Hp: VarName | None = None
    valid: VarName | None = None


class _FmuSection(Frozen):
    """What the exporter recorded about the FMU (informative; checked so that nothing odd passes)."""

    model_identifier: Annotated[str, Field(pattern=r"^[A-Za-z_][A-Za-z0-9_]{0,127}$")] | None = None
    guid: Annotated[str, Field(pattern=_GUID)] | None = None
    integrator: Literal[INTEGRATORS] | None = None
    step: quantity("s", gt=0.0, le=1.0e4) | None = None


class MappingFile(Frozen):
    """The mapping TOML file (see the module docstring), validated like a scenario."""

    format: Literal[1] = 1
    fmu: _FmuSection = _FmuSection()
    state: _StateSection
    correction: _CorrectionSection
    measurement: _MeasurementSection
    parameters: _ParametersSection = _ParametersSection()
    jacobians: _JacobianSection | None = None


def _mapping_path(problem) -> str:
    """``state.kinematics`` -> ``[state] kinematics``, as the file spells it."""
    section, _, rest = problem.path.partition(".")
    if section == "(scenario)":
        return "(mapping)"
    return f"[{section}] {rest}" if rest else (section if section in ("format",) else f"[{section}]")


def _validated(data, source: str) -> MappingFile:
    from pydantic import ValidationError

    from postcapture.config.loader import problems_from_validation

    if not isinstance(data, dict):
        raise FMIError(f"invalid mapping: expected a table of sections, found {type(data).__name__}", fmu=source,
                       function="mapping")
    try:
        return MappingFile.model_validate(data)
    except ValidationError as exc:
        problems = [f"{_mapping_path(p)}: expected {p.expected}, found {p.found}"
                    for p in problems_from_validation(exc, model=MappingFile)]
    except (RecursionError, ArithmeticError) as exc:
        problems = [f"(mapping): expected tables a few levels deep, found {type(exc).__name__}"]
    raise FMIError("invalid mapping:\n  - " + "\n  - ".join(problems), fmu=source, function="mapping")


def _relation_problems(file: MappingFile) -> list[str]:
    """What the schema cannot see: entries against each other."""
    st, corr = file.state, file.correction
    problems = _pattern_problems(file.jacobians) if file.jacobians is not None else []
    if len(st.variables) != len(corr.inputs):
        problems.append(f"[correction] inputs: expected {len(st.variables)} names (one per state entry), "
                        f"found {len(corr.inputs)}")
    par, jac = file.parameters, file.jacobians
    problems += _overlap_problems(st.variables, corr.inputs, corr.reset, st.attitude, st.rate, file.measurement.accel,
                                  file.measurement.joint_accel, par.mass, par.inputs)
    for key, names in (("attitude", st.attitude), ("rate", st.rate), ("velocity", st.velocity or ()),
                       ("arm", st.arm or ())):
        problems += [f"[state] {key}: {nm!r} is not one of state.variables" for nm in names if nm not in st.variables]
    problems += _parameter_problems(par, jac)
    if not problems:
        idx = {n: i for i, n in enumerate(st.variables)}
        problems += [f"[state] {p}" for p in layout_problems(st.kinematics, len(st.variables),
                                                             [idx[n] for n in st.attitude], [idx[n] for n in st.rate])]
    return problems


def _parameter_problems(par: _ParametersSection, jac: _JacobianSection | None) -> list[str]:
    """The parameter entries against each other and against the Jacobian patterns."""
    problems = []
    if par.names is not None and (par.inputs is None or len(par.names) != len(par.inputs)):
        problems.append(f"[parameters] names: expected one name per entry of [parameters] inputs "
                        f"({0 if par.inputs is None else len(par.inputs)}), found {len(par.names)}")
    if par.names is not None and _duplicates(par.names):
        problems.append(f"[parameters] names: {', '.join(repr(d) for d in _duplicates(par.names))} listed more than once")
    names = par.names or par.inputs or ()
    if par.mass_offset is not None:
        if par.mass is not None:
            problems.append("[parameters] mass_offset: expected either a mass variable or inputs with mass_offset, "
                            "found both")
        elif "target.m" not in names:
            problems.append("[parameters] mass_offset: expected [parameters] inputs holding 'target.m' (the mass is "
                            "target.m plus the offset), found none")
    if jac is not None:
        for key in ("G", "Hp"):
            if getattr(jac, key) is not None and par.inputs is None:
                problems.append(f"[jacobians] {key}: derivatives with respect to the parameter inputs, but "
                                "[parameters] names no inputs")
        if (jac.g is None) != (jac.h is None):
            problems.append("[jacobians] g, h: expected both (the mass derivatives of the step and of the "
                            "measurement) or neither")
        if (jac.G is None) != (jac.Hp is None):
            problems.append("[jacobians] G, Hp: expected both (the parameter derivatives of the step and of the "
                            "measurement) or neither")
    return problems


def mapping_sidecar(fmu_path: str | Path) -> Path:
    """The mapping file written beside an FMU: ``<stem>.mapping.toml`` (never the FMU's own name)."""
    fmu_path = Path(fmu_path)
    return fmu_path.with_name(f"{fmu_path.stem}.mapping.toml")


@dataclass(frozen=True)
class Mapping:
    """Which FMU variables a filter uses (see the module docstring).

    Attributes
    ----------
    state, correction : tuple of str
        The state variables (outputs) and the inputs that correct them, in the same order.
    reset : str
        The input whose value > 0.5 at ``fmi2DoStep`` replaces the state by the correction inputs.
    kinematics : {"free_flyer", "quaternion"}
    attitude : tuple of 4 str
        ``q_BN`` (w, x, y, z): entries of ``state``.
    rate : tuple of 3 str
        ``omega_BN_B`` (rad/s): entries of ``state``.
    accel : tuple of 3 str
        Chaser acceleration at the accelerometer, B components (m/s2).
    joint_accel : tuple of str
        Arm joint accelerations (rad/s2).
    mass : str or None
        A variable that is the target's mass (kg): a tunable parameter or an input.
    velocity : tuple of 3 str or None
        The chaser's linear velocity (B frame, m/s): entries of ``state`` (``free_flyer``: ``v[1..3]``).
    arm : tuple of str or None
        The arm's joint angles (rad), what its encoders read: entries of ``state``.
    accelerometer_position : tuple of 3 float or None
        The accelerometer's position in B (m).
    parameters : tuple of str or None
        Inputs holding the plant's parameter vector (held constant over a step).
    parameter_names : tuple of str or None
        postcapture's names of those entries (default: the inputs' own names).
    mass_offset : float or None
        With ``parameters`` and no ``mass``: the target's mass is ``target.m`` plus this (kg).
    jacobians : JacobianOutputs or None
        Exported step and measurement Jacobians.
    source : str
        Where the mapping came from (for messages).
    """

    state: tuple[str, ...]
    correction: tuple[str, ...]
    reset: str
    kinematics: str
    attitude: tuple[str, ...]
    rate: tuple[str, ...]
    accel: tuple[str, ...]
    joint_accel: tuple[str, ...]
    mass: str | None = None
    jacobians: JacobianOutputs | None = None
    info: dict = field(default_factory=dict)
    source: str = ""
    velocity: tuple[str, ...] | None = None
    arm: tuple[str, ...] | None = None
    accelerometer_position: tuple[float, ...] | None = None
    parameters: tuple[str, ...] | None = None
    parameter_names: tuple[str, ...] | None = None
    mass_offset: float | None = None

    # ------------------------------------------------------------------ files
    @classmethod
    def from_dict(cls, data: dict, source: str = "") -> Mapping:
        """Build from parsed TOML; every missing or malformed entry is reported at once.

        The file is validated as a scenario is (:class:`MappingFile`: strict types, unknown keys and sections
        with "did you mean", the ``[fmu]`` values bounded), then its entries against each other (no variable
        in two roles, Jacobian name patterns, the layout of the kinematics).

        Raises
        ------
        FMIError
            Listing every problem as ``[section] key: expected ..., found ...``.
        """
        file = _validated(data, source)
        problems = _relation_problems(file)
        if problems:
            raise FMIError("invalid mapping:\n  - " + "\n  - ".join(problems), fmu=source, function="mapping")
        st, m, par = file.state, file.measurement, file.parameters
        return cls(st.variables, file.correction.inputs, file.correction.reset, st.kinematics, st.attitude, st.rate,
                   m.accel, m.joint_accel, par.mass,
                   JacobianOutputs(**file.jacobians.model_dump()) if file.jacobians is not None else None,
                   file.fmu.model_dump(exclude_none=True), source, velocity=st.velocity, arm=st.arm,
                   accelerometer_position=m.accelerometer_position, parameters=par.inputs,
                   parameter_names=par.names or par.inputs, mass_offset=par.mass_offset)

    @classmethod
    def from_toml(cls, path: str | Path) -> Mapping:
        """Read a mapping file."""
        path = Path(path)
        try:
            text = path.read_text()
        except OSError as exc:
            raise FMIError(
                f"cannot read the mapping file: {exc.strerror or exc}", fmu=str(path), function="mapping"
            ) from exc
        return cls.from_text(text, source=str(path))

    @classmethod
    def from_text(cls, text: str, source: str = "") -> Mapping:
        """Parse mapping TOML text."""
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise FMIError(f"not valid TOML: {exc}", fmu=source, function="mapping") from exc
        except RecursionError:
            raise FMIError("not valid TOML: nested too deep to parse (a mapping is a few tables deep)", fmu=source,
                           function="mapping") from None
        return cls.from_dict(data, source)

    def to_dict(self) -> dict:
        """The TOML structure."""
        out = {"format": 1}
        if self.info:
            out["fmu"] = dict(self.info)
        out["state"] = {
            "variables": list(self.state),
            "kinematics": self.kinematics,
            "attitude": list(self.attitude),
            "rate": list(self.rate),
        }
        for key in ("velocity", "arm"):
            if getattr(self, key) is not None:
                out["state"][key] = list(getattr(self, key))
        out["correction"] = {"inputs": list(self.correction), "reset": self.reset}
        out["measurement"] = {"accel": list(self.accel), "joint_accel": list(self.joint_accel)}
        if self.accelerometer_position is not None:
            out["measurement"]["accelerometer_position"] = [float(c) for c in self.accelerometer_position]
        par = {}
        if self.mass is not None:
            par["mass"] = self.mass
        if self.parameters is not None:
            par["inputs"] = list(self.parameters)
            if self.parameter_names is not None and tuple(self.parameter_names) != tuple(self.parameters):
                par["names"] = list(self.parameter_names)
        if self.mass_offset is not None:
            par["mass_offset"] = float(self.mass_offset)
        if par:
            out["parameters"] = par
        if self.jacobians is not None:
            j = self.jacobians
            out["jacobians"] = {k: getattr(j, k) for k in ("request", "F", "H", "g", "h", "G", "Hp", "valid")
                                if getattr(j, k) is not None}
        return out

    def to_toml(self) -> str:
        """TOML text with a header comment."""
        import tomli_w

        head = (
            "# postcapture mapping: which variables of modelDescription.xml a filter uses.\n"
            "# See postcapture.fmi.mapping for the meaning of each entry.\n"
        )
        return head + tomli_w.dumps(self.to_dict())

    # ------------------------------------------------------------------ queries
    @property
    def n_meas(self) -> int:
        """Measurement size ``3 + len(joint_accel)``."""
        return 3 + len(self.joint_accel)

    def entries(self) -> list[tuple[str, str]]:
        """``(entry, variable name)`` for every name the mapping uses (Jacobian patterns expanded apart)."""
        out = [("state.variables", n) for n in self.state]
        out += [("correction.inputs", n) for n in self.correction]
        out.append(("correction.reset", self.reset))
        out += [("measurement.accel", n) for n in self.accel]
        out += [("measurement.joint_accel", n) for n in self.joint_accel]
        if self.mass is not None:
            out.append(("parameters.mass", self.mass))
        out += [("parameters.inputs", n) for n in self.parameters or ()]
        if self.jacobians is not None:
            out.append(("jacobians.request", self.jacobians.request))
            if self.jacobians.valid is not None:
                out.append(("jacobians.valid", self.jacobians.valid))
        return out

    @property
    def mass_from_parameters(self) -> bool:
        """Whether the target's mass is ``target.m`` of the parameter inputs plus ``mass_offset``."""
        return self.mass is None and self.mass_offset is not None and self.parameters is not None


_ROLES = {
    # entry: (causalities allowed, variabilities allowed or None, what it must be)
    "state.variables": ({"output", "local"}, None, "a readable output"),
    "measurement.accel": ({"output", "local"}, None, "a readable output"),
    "measurement.joint_accel": ({"output", "local"}, None, "a readable output"),
    "correction.inputs": ({"input"}, None, "an input (set before each step)"),
    "correction.reset": ({"input"}, None, "an input (set before each step)"),
    "jacobians.request": ({"input"}, None, "an input"),
    "jacobians.valid": ({"output", "local"}, None, "a readable output"),
    "parameters.mass": ({"parameter", "input"}, {"tunable", "continuous", "discrete"},
                        "a tunable parameter or an input"),
    "parameters.inputs": ({"input"}, {"continuous"}, "a continuous input (held constant over a step)"),
}
_REAL_TYPES = ("Real", "Float64")


def _close(name: str, pool: list[str]) -> str:
    close = difflib.get_close_matches(name, pool, n=4, cutoff=0.6)
    return f"; close matches: {', '.join(close)}" if close else ""


def _entry_problem(entry: str, name: str, by_name: dict, pool: list[str]) -> str | None:
    """What is wrong with one mapped name against the FMU's variables (None when it fits)."""
    if name not in by_name:
        return f"{entry}: no variable {name!r} in the FMU{_close(name, pool)}"
    v = by_name[name]
    if v is None:
        return None
    causalities, variabilities, what = _ROLES[entry]
    if v.causality not in causalities or (variabilities is not None and v.variability not in variabilities):
        return (f"{entry}: {name!r} has causality {v.causality!r} and variability {v.variability!r}; "
                f"expected {what}")
    if v.type not in _REAL_TYPES:
        return f"{entry}: {name!r} is of type {v.type}; expected a real (Real / Float64) variable"
    return None


def _jacobian_problems(jac: JacobianOutputs, n: int, m: int, n_p: int, by_name: dict, pool: list[str]) -> list[str]:
    problems = []
    for key, group in jac.expand(n, m, n_p).items():
        missing = [g for g in group if g not in by_name]
        if missing:
            problems.append(f"jacobians.{key}: {len(missing)} of {len(group)} variables missing, "
                            f"first {missing[0]!r}{_close(missing[0], pool)}")
        elif by_name[group[0]] is not None:
            unreadable = [g for g in group if by_name[g].causality not in ("output", "local")]
            if unreadable:
                problems.append(f"jacobians.{key}: {len(unreadable)} of {len(group)} variables are not outputs, "
                                f"first {unreadable[0]!r}")
    return problems


def check_mapping(mapping: Mapping, variables, fmu: str, tangent_dim: int | None = None) -> list[str]:
    """Problems of ``mapping`` against an FMU's variables (empty when it fits).

    Parameters
    ----------
    mapping : Mapping
    variables : iterable of str, or of FMPy ``ModelVariable``
        The FMU's variable names, or its variables: then causality, variability and type are checked
        too (corrections, the reset flag and the parameter vector inputs, the mass a tunable parameter or
        an input, the state and the measurements outputs, all of them real-valued).
    fmu : str
        The FMU (for messages).
    tangent_dim : int, optional
        Tangent size, to check the expanded Jacobian output names.

    Returns
    -------
    list of str
        One message per problem; a missing name comes with the closest existing names (``difflib``).
    """
    variables = list(variables)
    by_name = {v: None for v in variables} if all(isinstance(v, str) for v in variables) else \
        {v.name: v for v in variables}
    pool = sorted(by_name)
    problems = [p for entry, name in mapping.entries() if (p := _entry_problem(entry, name, by_name, pool))]
    if mapping.jacobians is not None and tangent_dim is not None:
        problems += _jacobian_problems(mapping.jacobians, tangent_dim, mapping.n_meas, len(mapping.parameters or ()),
                                       by_name, pool)
    return problems


def load_mapping(fmu_path: str | Path, mapping: str | Path | Mapping | None = None) -> Mapping:
    """The mapping of an FMU: the one given, else the FMU's embedded one, else ``<stem>.mapping.toml``
    beside it (else ``<stem>.toml``, as earlier versions named it).

    Raises
    ------
    FMIError
        When no mapping is found or it is invalid.
    """
    import zipfile

    if isinstance(mapping, Mapping):
        return mapping
    if mapping is not None:
        return Mapping.from_toml(mapping)
    fmu_path = Path(fmu_path)
    try:
        with zipfile.ZipFile(fmu_path) as zf:
            if "resources/postcapture_mapping.toml" in zf.namelist():
                text = zf.read("resources/postcapture_mapping.toml").decode()
                return Mapping.from_text(text, source=f"{fmu_path}!resources/postcapture_mapping.toml")
    except zipfile.BadZipFile as exc:
        raise FMIError("not a ZIP archive (an FMU is one)", fmu=str(fmu_path), function="open") from exc
    side = mapping_sidecar(fmu_path)
    if side.is_file():
        return Mapping.from_toml(side)
    legacy = fmu_path.with_suffix(".toml")  # the name used before 0.2 (it could collide with the FMU's own)
    if legacy.is_file() and legacy != fmu_path:
        return Mapping.from_toml(legacy)
    raise FMIError(
        "no mapping: pass one (a TOML file naming the state, correction inputs, reset flag, attitude, rates, "
        f"measurements and mass parameter), or put it in resources/postcapture_mapping.toml or {side.name}",
        fmu=str(fmu_path),
        function="mapping",
    )
