"""What the filters do not know: priors on the target, the flexibility, the sensor biases (``[uncertainty]``).

A scenario's nominal values are what every filter's model is built from; ``[uncertainty]`` declares how
far the real system may be from them. The same priors serve twice: the filters take their covariances
from them (a consistent filter must know how wrong its model may be), and ``postcapture run
--truth-draw SEED`` or ``postcapture campaign --dispersed`` draw truths from them.

Every entry is a :class:`Prior`, in SI units, of one of two sorts:

- *offsets* added to the nominal value: ``target_mass`` (kg), ``target_com`` (m, each axis of T),
  ``target_inertia_axes`` (rad, a small rotation of the principal axes about each axis of T),
  ``gyro_bias`` (rad/s, each axis, the turn-on bias), ``accelerometer_bias`` (m/s^2, each axis),
  ``gyro_scale_factor`` (relative, each axis) and ``gyro_misalignment`` (rad, each of the six
  off-axis terms): the gyro unit's calibration errors, which the filters then estimate;
- *factors* multiplying it: ``target_inertia_moments`` (each principal moment), ``panel_bending``,
  ``panel_torsion`` and ``panel_damping`` (each panel drawn on its own), ``arm_stiffness`` and
  ``arm_damping`` (one factor for every joint).

``truth_panel_segments`` cuts the truth's panels into that many segments (the filters keep the
nominal count): the discretisation is a model error no parameter can absorb.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, model_validator

from postcapture.config.types import MAX_MASS, Frozen, problem, problems

__all__ = ["Prior", "Uncertainty", "OFFSET_PRIORS", "FACTOR_PRIORS", "prior_field"]

_MAX_VALUE = 1.0e12  # no prior parameter of this project comes near it; each prior's own bound is tighter

OFFSET_PRIORS = ("target_mass", "target_com", "target_inertia_axes", "gyro_bias", "accelerometer_bias",
                 "gyro_scale_factor", "gyro_misalignment")
FACTOR_PRIORS = ("target_inertia_moments", "panel_bending", "panel_torsion", "panel_damping", "arm_stiffness",
                 "arm_damping")


class Prior(Frozen):
    """A distribution: ``normal`` (``sigma``, cut at ``truncate`` sigmas), ``uniform`` or ``loguniform`` (``low``, ``high``).

    For an offset, a normal is centred on 0 and ``low``/``high`` are offsets; for a factor, a normal is
    ``1 + sigma n`` and ``low``/``high`` are factors.

    Attributes
    ----------
    kind : {"normal", "uniform", "loguniform"}
        The distribution.
    sigma : float
        A normal prior's standard deviation, in the prior's unit.
    truncate : float
        A normal prior is cut at this many sigmas (draws beyond are drawn again).
    low, high : float
        A uniform or log-uniform prior's range, in the prior's unit.
    """

    kind: Literal["normal", "uniform", "loguniform"] = "normal"
    sigma: Annotated[float, Field(gt=0.0, le=_MAX_VALUE)] | None = None
    truncate: Annotated[float, Field(ge=0.5, le=10.0)] = 3.0  # draws beyond it are drawn again: a few rounds
    low: Annotated[float, Field(ge=-_MAX_VALUE, le=_MAX_VALUE)] | None = None
    high: Annotated[float, Field(ge=-_MAX_VALUE, le=_MAX_VALUE)] | None = None

    @model_validator(mode="after")
    def _fields(self):
        if self.kind == "normal":
            if self.sigma is None or self.low is not None or self.high is not None:
                raise problem("a normal prior with 'sigma' (and optionally 'truncate'), without low/high",
                              self.model_dump(exclude_defaults=True))
        else:
            if self.sigma is not None or self.low is None or self.high is None:
                raise problem(f"a {self.kind} prior with 'low' and 'high', without sigma", self.model_dump(exclude_defaults=True))
            if not self.high > self.low:
                raise problem(f"high > low = {self.low}", self.high)
            if self.kind == "loguniform" and not self.low > 0:
                raise problem("low > 0 for a loguniform prior", self.low)
        return self

    def sample(self, rng: np.random.Generator, size=None, *, factor: bool = False):
        """Draws (offsets around 0, or factors around 1)."""
        if self.kind == "normal":
            t = self.truncate
            if size is None:  # one draw: plain floats (the same stream as the array path)
                n = rng.standard_normal()
                while abs(n) > t:
                    n = rng.standard_normal()
                return (1.0 if factor else 0.0) + self.sigma * n
            n = rng.standard_normal(size)
            bad = np.abs(n) > t
            while np.any(bad):  # truncation by rejection (t >= a fraction of a sigma: few rounds)
                n[bad] = rng.standard_normal(int(np.count_nonzero(bad)))
                bad = np.abs(n) > t
            return (1.0 if factor else 0.0) + self.sigma * n
        if self.kind == "uniform":
            return rng.uniform(self.low, self.high, size)
        return np.exp(rng.uniform(math.log(self.low), math.log(self.high), size))

    def extremes(self, *, factor: bool = False) -> tuple[float, float]:
        """The smallest and the largest value a draw can take."""
        if self.kind == "normal":
            c = 1.0 if factor else 0.0
            return c - self.truncate * self.sigma, c + self.truncate * self.sigma
        return float(self.low), float(self.high)

    def rms_about(self, nominal: float, *, factor: bool = False) -> float:
        """Root mean square of ``draw - nominal``: the 1-sigma a filter built at ``nominal`` should assume."""
        if self.kind == "normal":
            t = self.truncate
            phi = math.exp(-0.5 * t * t) / math.sqrt(2.0 * math.pi)
            var = self.sigma**2 * (1.0 - 2.0 * t * phi / math.erf(t / math.sqrt(2.0)))
            centre = 1.0 if factor else 0.0
            return math.sqrt(var + (centre - nominal) ** 2)
        a, b = float(self.low), float(self.high)
        if self.kind == "uniform":
            mean, second = 0.5 * (a + b), (a * a + a * b + b * b) / 3.0
        else:
            L = math.log(b / a)
            mean, second = (b - a) / L, (b * b - a * a) / (2.0 * L)
        return math.sqrt(max(second - 2.0 * nominal * mean + nominal * nominal, 0.0))


def prior_field(unit: str, role: str, limit: float):
    """A prior of the ``[uncertainty]`` section, declared once with its unit and physical bound.

    ``role`` is ``"offset"`` (draws are added to the nominal value; every draw's magnitude must stay at most
    ``limit``) or ``"factor"`` (draws multiply it; they must stay in ``(0, limit]``). The bound is checked
    when the scenario is loaded and listed in the field reference.
    """
    return Field(default=None, json_schema_extra={"unit": unit, "role": role, "limit": limit})


class Uncertainty(Frozen):
    """Declared uncertainty of the nominal model (see the module docstring); None means exactly known.

    Attributes
    ----------
    target_mass : Prior
        Offset on the target's mass (kg).
    target_com : Prior
        Offset on each axis of the target's centre of mass, in T (m).
    target_inertia_moments : Prior
        Factor on each principal moment of the target.
    target_inertia_axes : Prior
        Small rotation of the target's principal axes about each axis of T (rad).
    panel_bending, panel_torsion, panel_damping : Prior
        Factors on each panel's hinge springs and dampers (each panel drawn on its own).
    arm_stiffness, arm_damping : Prior
        One factor on every arm joint's spring or damper.
    gyro_bias : Prior
        The gyro's turn-on bias per axis (rad/s).
    accelerometer_bias : Prior
        The accelerometer's bias per axis (m/s^2).
    gyro_scale_factor : Prior
        The gyro's scale-factor error per axis (relative).
    gyro_misalignment : Prior
        The gyro's misalignment, each of its six off-axis terms (rad).
    truth_panel_segments : int
        The truth's panels are cut into this many segments (the filters keep the scenario's).
    """

    target_mass: Prior | None = prior_field("kg", "offset", MAX_MASS)
    target_com: Prior | None = prior_field("m", "offset", 10.0)
    target_inertia_moments: Prior | None = prior_field("1", "factor", 10.0)
    target_inertia_axes: Prior | None = prior_field("rad", "offset", 0.5)
    panel_bending: Prior | None = prior_field("1", "factor", 10.0)
    panel_torsion: Prior | None = prior_field("1", "factor", 10.0)
    panel_damping: Prior | None = prior_field("1", "factor", 100.0)
    arm_stiffness: Prior | None = prior_field("1", "factor", 10.0)
    arm_damping: Prior | None = prior_field("1", "factor", 100.0)
    gyro_bias: Prior | None = prior_field("rad/s", "offset", 0.01)
    accelerometer_bias: Prior | None = prior_field("m/s^2", "offset", 1.0)
    gyro_scale_factor: Prior | None = prior_field("1", "offset", 0.01)
    gyro_misalignment: Prior | None = prior_field("rad", "offset", 0.01)
    truth_panel_segments: int | None = Field(default=None, ge=1, le=1000)

    @model_validator(mode="after")
    def _within_physical_bounds(self):
        found = []
        for name, info in type(self).model_fields.items():
            prior, extra = getattr(self, name), info.json_schema_extra or {}
            if not isinstance(prior, Prior) or "role" not in extra:
                continue
            factor = extra["role"] == "factor"
            lo, hi = prior.extremes(factor=factor)
            unit = "" if extra["unit"] == "1" else f" {extra['unit']}"
            if factor and lo <= 0.0:
                found.append((f"uncertainty.{name}", "draws of a factor that stay > 0 (lower the sigma or the "
                                                     "truncation)", f"draws down to {lo:.3g}"))
            elif factor and hi > extra["limit"]:
                found.append((f"uncertainty.{name}", f"draws of a factor of at most {extra['limit']:g}",
                              f"draws up to {hi:.3g}"))
            elif not factor and max(abs(lo), abs(hi)) > extra["limit"]:
                found.append((f"uncertainty.{name}", f"draws within +-{extra['limit']:g}{unit} of the nominal value",
                              f"draws up to {max(abs(lo), abs(hi)):.3g}{unit}"))
        if found:
            raise problems(found)
        return self

    def factor(self, name: str, nominal: float = 1.0) -> float:
        """1-sigma (RMS about ``nominal``) of a factor prior; 0 when exactly known."""
        prior = getattr(self, name)
        return 0.0 if prior is None else prior.rms_about(nominal, factor=True)

    def offset(self, name: str) -> float:
        """1-sigma (RMS about 0) of an offset prior; 0 when exactly known."""
        prior = getattr(self, name)
        return 0.0 if prior is None else prior.rms_about(0.0)
