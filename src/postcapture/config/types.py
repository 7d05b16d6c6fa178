"""Shared field types and physical validators of the scenario schema.

Every validator raises :class:`pydantic_core.PydanticCustomError` with ``expected`` and ``found`` in
its context, so that :mod:`postcapture.config.loader` can report each problem as
``path: expected ..., found ...``.

Types are strict: a boolean is not a number (``mass = true`` is an error, not 1.0), a string is not a
number (``"1.5"``), a fractional number is not an integer (``segments = 5.0``) and a number is not a
boolean. Integers are accepted where a real number is expected. TOML arrays (Python lists) are
accepted where the schema has tuples.
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import AfterValidator, BaseModel, ConfigDict, Field, model_validator
from pydantic_core import PydanticCustomError

__all__ = [
    "quantity",
    "vector",
    "Name",
    "Text",
    "Mass",
    "Length",
    "Size",
    "Angle",
    "Stiffness",
    "Damping",
    "Duration",
    "Instant",
    "Frequency",
    "Position3",
    "Angles3",
    "Frozen",
    "SEED_LIMIT",
    "Seed",
    "Vec3",
    "Mat3",
    "PositiveFloat",
    "NonNegativeFloat",
    "Pose",
    "AxisName",
    "problem",
    "problems",
    "check_inertia",
    "rpy_matrix",
]


def problem(expected: str, found: object, path: str | None = None, *, field: str | None = None) -> PydanticCustomError:
    """A validation error whose message reads ``expected ..., found ...``.

    ``path`` names the field when a check on a whole scenario is about one of its fields (for example
    ``faults[0].stop``); the loader reports it instead of the scenario's own path. ``field`` names a field of
    the section being validated: the loader appends it to the section's path (``faults[2].step``).
    """
    ctx = {"expected": expected, "found": str(found)}
    if path is not None:
        ctx["path"] = path
    if field is not None:
        ctx["field"] = field
    return PydanticCustomError("scenario", "expected {expected}, found {found}", ctx)


def problems(found: list[tuple[str, str, object]]) -> PydanticCustomError:
    """Several problems of one check, each ``(path, expected, found)``: the loader reports every one of them."""
    if len(found) == 1:
        path, expected, value = found[0]
        return problem(expected, value, path)
    listed = [{"path": p, "expected": e, "found": str(f)} for p, e, f in found]
    return PydanticCustomError("scenario_many", "{count} problems", {"count": len(listed), "problems": listed})


_MAX_ARRAY_DEPTH = 8  # deeper arrays than any field has are left as lists: the type check reports them


def _as_tuples(value, depth: int = 0):
    """TOML arrays (lists) as tuples, nested ones too (tables inside are left to their own model).

    From Python, numpy arrays and scalars are taken as the Python values they hold (``np.int64(4)`` is
    an integer, ``np.bool_(True)`` a boolean, and so still not a number).
    """
    if isinstance(value, np.ndarray):
        value = value.tolist()
    elif isinstance(value, np.generic):
        return value.item()
    if isinstance(value, list | tuple) and depth < _MAX_ARRAY_DEPTH:
        return tuple(_as_tuples(v, depth + 1) for v in value)
    return value


class Frozen(BaseModel):
    """Base of every scenario object: immutable, no unknown keys, finite numbers only, strict types.

    Strict mode refuses the lax conversions (bool to number, string to number, float to int, number
    to bool); tuples would then refuse lists, so lists become tuples before validation.
    """

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False, validate_default=True, strict=True)

    @model_validator(mode="before")
    @classmethod
    def _arrays_as_tuples(cls, data):
        if isinstance(data, dict):
            return {k: _as_tuples(v) for k, v in data.items()}
        return data


SEED_LIMIT = 2**63
"""Seeds are integers in ``[0, SEED_LIMIT)``: they are written into the results files as int64."""
Seed = Annotated[int, Field(ge=0, lt=SEED_LIMIT)]
PositiveFloat = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0.0, allow_inf_nan=False)]
Vec3 = tuple[float, float, float]
Mat3 = tuple[Vec3, Vec3, Vec3]
AxisName = Literal["x", "y", "z"]


# ------------------------------------------------------------------------------------------ quantities
def quantity(unit: str, *, gt: float | None = None, ge: float | None = None, lt: float | None = None,
             le: float | None = None):
    """A real number in SI units with its physical bounds, declared once where the field is declared.

    The bounds are what a body, a spring or a sensor of this project can physically be, wide enough for
    any spacecraft and narrow enough that nothing within them overflows later. The unit and the bounds
    are read back by the field reference (:mod:`postcapture.config.reference`).

    Examples
    --------
    >>> from pydantic import TypeAdapter
    >>> TypeAdapter(quantity("kg", gt=0, le=1e7)).validate_python(5.0)
    5.0
    """
    return Annotated[float, Field(gt=gt, ge=ge, lt=lt, le=le, allow_inf_nan=False, json_schema_extra={"unit": unit})]


def vector(unit: str, limit: float):
    """Three components in SI units, each of magnitude at most ``limit``."""
    c = quantity(unit, ge=-limit, le=limit)
    return Annotated[tuple[c, c, c], Field(json_schema_extra={"unit": unit})]


NAME_PATTERN = r"^[A-Za-z][A-Za-z0-9_.-]{0,63}$"
Name = Annotated[str, Field(pattern=NAME_PATTERN, json_schema_extra={"unit": "name"})]
"""A name that becomes part of variable, dimension and file names: an ASCII letter, then up to 63 ASCII letters,
digits, ``_``, ``.`` or ``-`` (no spaces, control or combining characters)."""
Text = Annotated[str, Field(max_length=4000, pattern=r"^[^\x00-\x08\x0b-\x1f\x7f]*$")]
"""Free text (a description): no control characters but tab and newline, at most 4000 characters."""

MAX_MASS = 1.0e7  # kg: ten times the largest spacecraft yet built
MAX_LENGTH = 1.0e3  # m: positions and sizes of parts of one spacecraft stack
MAX_TIME = 1.0e6  # s: eleven and a half days of simulated time
Mass = quantity("kg", gt=0.0, le=MAX_MASS)
Length = quantity("m", ge=-MAX_LENGTH, le=MAX_LENGTH)
Size = quantity("m", gt=0.0, le=MAX_LENGTH)
Angle = quantity("rad", ge=-6.283185307179586, le=6.283185307179586)
Stiffness = quantity("N m/rad", gt=0.0, le=1.0e12)
Damping = quantity("N m s/rad", ge=0.0, le=1.0e12)
Duration = quantity("s", gt=0.0, le=MAX_TIME)
Instant = quantity("s", ge=0.0, le=MAX_TIME)
Frequency = quantity("Hz", gt=0.0, le=1.0e4)
Position3 = vector("m", MAX_LENGTH)
Angles3 = vector("rad", 6.283185307179586)


MAX_INERTIA = 1.0e10  # kg m^2: a 1e7 kg body 30 m in radius


def _check_inertia(value: Mat3) -> Mat3:
    I = np.array(value, dtype=float)
    scale = float(np.abs(I).max())
    if not scale <= MAX_INERTIA:  # no body of a spacecraft stack is that large
        raise problem(f"inertia entries of magnitude at most {MAX_INERTIA:g} kg m^2", f"an entry of {scale:.6g}")
    if not np.allclose(I, I.T, rtol=1e-9, atol=1e-9 * max(1.0, scale)):
        raise problem("a symmetric 3x3 inertia tensor", f"I - I^T with max |entry| {np.abs(I - I.T).max():.3g}")
    eig = np.linalg.eigvalsh(I)
    if eig[0] <= 0.0:
        raise problem("a positive definite inertia tensor (kg m^2)", f"eigenvalues {np.round(eig, 6).tolist()}")
    a, b, c = eig
    # Principal moments of a physical body satisfy the triangle inequality A + B >= C.
    if a + b < c * (1.0 - 1e-9):
        raise problem(
            "principal moments satisfying the triangle inequality (I1 + I2 >= I3)",
            f"{a:.6g} + {b:.6g} < {c:.6g}",
        )
    return value


check_inertia = AfterValidator(_check_inertia)


def rpy_matrix(rpy) -> np.ndarray:
    """Rotation matrix of URDF roll-pitch-yaw angles (rad): ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    The matrix maps vectors in the child frame to the parent frame (an active rotation, as URDF).
    """
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


class Pose(Frozen):
    """Placement of a child frame in a parent frame, URDF style.

    ``xyz`` is the child origin in parent components (m); ``rpy`` are roll-pitch-yaw angles (rad) with
    ``R_parent_child = Rz(yaw) Ry(pitch) Rx(roll)``.

    Attributes
    ----------
    xyz : list of 3 float
        The child frame's origin in the parent frame (m).
    rpy : list of 3 float
        Roll, pitch, yaw (rad): ``R_parent_child = Rz(yaw) Ry(pitch) Rx(roll)``.
    """

    xyz: Position3 = (0.0, 0.0, 0.0)
    rpy: Angles3 = (0.0, 0.0, 0.0)

    def rotation(self) -> np.ndarray:
        """Rotation matrix mapping child components to parent components."""
        return rpy_matrix(self.rpy)

    def translation(self) -> np.ndarray:
        """Child origin in parent components (m)."""
        return np.array(self.xyz, dtype=float)
