"""The mapping file: which variables of an FMU's ``modelDescription.xml`` a filter uses.

A mapping names, by their FMI variable names, the state vector and its kinematics, the attitude and
body rate inside it, the measurement (chaser acceleration, arm joint accelerations), the target-mass
parameter, how the state is corrected (inputs plus a reset flag) and, optionally, exported Jacobian
outputs. It is a small TOML file; :func:`postcapture.fmi.export_fmu` writes one for its FMUs (inside
the FMU under ``resources/postcapture_mapping.toml`` and next to it as ``<name>.toml``).

An example (the mapping of an exported plant, shortened):

.. code-block:: toml

    format = 1

    [state]
    variables = ["q[1]", "q[2]", "...", "v[25]"]   # x, in order
    kinematics = "free_flyer"   # or "quaternion"
    attitude = ["q[7]", "q[4]", "q[5]", "q[6]"]     # q_BN (w, x, y, z), entries of x
    rate = ["v[4]", "v[5]", "v[6]"]                 # omega_BN_B (rad/s), entries of x

    [correction]
    inputs = ["x_corr[1]", "...", "x_corr[51]"]    # same order as state.variables
    reset = "reset"                                 # > 0.5 at fmi2DoStep: the state becomes the inputs

    [measurement]
    accel = ["accel_B_x", "accel_B_y", "accel_B_z"] # m/s2, B frame
    joint_accel = ["arm_ddq_1", "...", "arm_ddq_7"] # rad/s2

    [parameters]
    mass = "target_mass"                            # kg, tunable

    [jacobians]                                     # optional: exact step Jacobians as outputs
    request = "jacobian_request"
    F = "F[{i},{j}]"
    g = "g[{i}]"
    H = "H[{i},{j}]"
    h = "h[{i}]"

Kinematics: ``free_flyer`` is a Pinocchio free-flyer state ``x = [q (nq), v (nq - 1)]`` (position,
quaternion x y z w, joint angles; body twist, joint rates) with right-perturbation tangents;
``quaternion`` is any state holding a unit quaternion ``q_BN`` (the ``attitude`` entries): its tangent
puts the body-frame attitude error first, then every other entry of ``x`` in order.
"""

from __future__ import annotations

import difflib
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from postcapture.core.errors import FMIError

__all__ = ["KINEMATICS", "JacobianOutputs", "Mapping", "load_mapping", "check_mapping"]

KINEMATICS = ("free_flyer", "quaternion")


@dataclass(frozen=True)
class JacobianOutputs:
    """Names of exported Jacobian outputs: patterns with ``{i}`` and ``{j}`` (1-based)."""

    request: str
    F: str
    g: str
    H: str
    h: str

    def expand(self, n: int, m: int) -> dict[str, list[str]]:
        """Every name: ``F`` (n x n, row-major), ``g`` (n), ``H`` (m x n), ``h`` (m)."""
        return {
            "F": [self.F.format(i=i + 1, j=j + 1) for i in range(n) for j in range(n)],
            "g": [self.g.format(i=i + 1) for i in range(n)],
            "H": [self.H.format(i=i + 1, j=j + 1) for i in range(m) for j in range(n)],
            "h": [self.h.format(i=i + 1) for i in range(m)],
        }


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
        Tunable target-mass parameter (kg).
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

    # ------------------------------------------------------------------ files
    @classmethod
    def from_dict(cls, data: dict, source: str = "") -> Mapping:
        """Build from parsed TOML; every missing or malformed entry is reported at once."""
        problems = []

        def get(section, key, kind, n=None, required=True):
            sec = data.get(section, {})
            if not isinstance(sec, dict):
                problems.append(f"[{section}] must be a table")
                return None
            val = sec.get(key)
            if val is None:
                if required:
                    problems.append(f"[{section}] {key}: missing")
                return None
            if kind is str and not isinstance(val, str):
                problems.append(f"[{section}] {key}: expected a variable name, found {val!r}")
                return None
            if kind is list:
                if not isinstance(val, list) or not all(isinstance(s, str) for s in val):
                    problems.append(f"[{section}] {key}: expected a list of variable names")
                    return None
                if n is not None and len(val) != n:
                    problems.append(f"[{section}] {key}: expected {n} names, found {len(val)}")
                    return None
                return tuple(val)
            return val

        state = get("state", "variables", list)
        kin = get("state", "kinematics", str)
        attitude = get("state", "attitude", list, 4)
        rate = get("state", "rate", list, 3)
        corr = get("correction", "inputs", list)
        reset = get("correction", "reset", str)
        accel = get("measurement", "accel", list, 3)
        joint = get("measurement", "joint_accel", list) or ()
        mass = get("parameters", "mass", str, required=False)
        jac = None
        if "jacobians" in data:
            parts = [get("jacobians", k, str) for k in ("request", "F", "g", "H", "h")]
            if all(p is not None for p in parts):
                jac = JacobianOutputs(*parts)
        if kin is not None and kin not in KINEMATICS:
            problems.append(f"[state] kinematics: expected one of {', '.join(KINEMATICS)}, found {kin!r}")
        if state is not None and corr is not None and len(state) != len(corr):
            problems.append(
                f"[correction] inputs: expected {len(state)} names (one per state entry), found {len(corr)}"
            )
        if state is not None:
            for key, names in (("attitude", attitude), ("rate", rate)):
                for nm in names or ():
                    if nm not in state:
                        problems.append(f"[state] {key}: {nm!r} is not one of state.variables")
        if problems:
            raise FMIError("invalid mapping:\n  - " + "\n  - ".join(problems), fmu=source, function="mapping")
        return cls(
            state,
            corr,
            reset,
            kin,
            attitude,
            rate,
            accel,
            tuple(joint),
            mass,
            jac,
            dict(data.get("fmu", {})),
            source,
        )

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
        out["correction"] = {"inputs": list(self.correction), "reset": self.reset}
        out["measurement"] = {"accel": list(self.accel), "joint_accel": list(self.joint_accel)}
        if self.mass is not None:
            out["parameters"] = {"mass": self.mass}
        if self.jacobians is not None:
            j = self.jacobians
            out["jacobians"] = {"request": j.request, "F": j.F, "g": j.g, "H": j.H, "h": j.h}
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
        if self.jacobians is not None:
            out.append(("jacobians.request", self.jacobians.request))
        return out


def check_mapping(
    mapping: Mapping, names: set[str] | list[str], fmu: str, tangent_dim: int | None = None
) -> list[str]:
    """Problems of ``mapping`` against an FMU's variable names (empty when every name exists).

    Each missing name is reported with the closest existing names (``difflib``).
    """
    names = set(names)
    pool = sorted(names)
    problems = []
    for entry, name in mapping.entries():
        if name not in names:
            close = difflib.get_close_matches(name, pool, n=4, cutoff=0.6)
            hint = f"; close matches: {', '.join(close)}" if close else ""
            problems.append(f"{entry}: no variable {name!r} in the FMU{hint}")
    if mapping.jacobians is not None and tangent_dim is not None:
        for key, group in mapping.jacobians.expand(tangent_dim, mapping.n_meas).items():
            missing = [g for g in group if g not in names]
            if missing:
                close = difflib.get_close_matches(missing[0], pool, n=4, cutoff=0.6)
                hint = f"; close matches: {', '.join(close)}" if close else ""
                problems.append(
                    f"jacobians.{key}: {len(missing)} of {len(group)} variables missing, "
                    f"first {missing[0]!r}{hint}"
                )
    return problems


def load_mapping(fmu_path: str | Path, mapping: str | Path | Mapping | None = None) -> Mapping:
    """The mapping of an FMU: the one given, else the FMU's embedded one, else ``<fmu>.toml`` beside it.

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
    side = fmu_path.with_suffix(".toml")
    if side.is_file():
        return Mapping.from_toml(side)
    raise FMIError(
        "no mapping: pass one (a TOML file naming the state, correction inputs, reset flag, attitude, rates, "
        f"measurements and mass parameter), or put it in resources/postcapture_mapping.toml or {side.name}",
        fmu=str(fmu_path),
        function="mapping",
    )
