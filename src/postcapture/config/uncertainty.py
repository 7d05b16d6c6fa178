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
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from postcapture.config.types import Frozen, PositiveFloat, problem

__all__ = ["Prior", "Uncertainty", "OFFSET_PRIORS", "FACTOR_PRIORS"]

OFFSET_PRIORS = ("target_mass", "target_com", "target_inertia_axes", "gyro_bias", "accelerometer_bias",
                 "gyro_scale_factor", "gyro_misalignment")
FACTOR_PRIORS = ("target_inertia_moments", "panel_bending", "panel_torsion", "panel_damping", "arm_stiffness",
                 "arm_damping")


class Prior(Frozen):
    """A distribution: ``normal`` (``sigma``, cut at ``truncate`` sigmas), ``uniform`` or ``loguniform`` (``low``, ``high``).

    For an offset, a normal is centred on 0 and ``low``/``high`` are offsets; for a factor, a normal is
    ``1 + sigma n`` and ``low``/``high`` are factors.
    """

    kind: Literal["normal", "uniform", "loguniform"] = "normal"
    sigma: PositiveFloat | None = None
    truncate: PositiveFloat = 3.0
    low: float | None = Field(default=None, allow_inf_nan=False)
    high: float | None = Field(default=None, allow_inf_nan=False)

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


class Uncertainty(Frozen):
    """Declared uncertainty of the nominal model (see the module docstring); None means exactly known."""

    target_mass: Prior | None = None
    target_com: Prior | None = None
    target_inertia_moments: Prior | None = None
    target_inertia_axes: Prior | None = None
    panel_bending: Prior | None = None
    panel_torsion: Prior | None = None
    panel_damping: Prior | None = None
    arm_stiffness: Prior | None = None
    arm_damping: Prior | None = None
    gyro_bias: Prior | None = None
    accelerometer_bias: Prior | None = None
    gyro_scale_factor: Prior | None = None
    gyro_misalignment: Prior | None = None
    truth_panel_segments: int | None = Field(default=None, ge=1, le=1000)

    @model_validator(mode="after")
    def _factors_stay_positive(self):
        for name in FACTOR_PRIORS:
            prior = getattr(self, name)
            if prior is not None and prior.extremes(factor=True)[0] <= 0.0:
                raise problem("draws of a factor that stay > 0 (lower the sigma or the truncation)",
                              f"draws down to {prior.extremes(factor=True)[0]:.3g}", f"uncertainty.{name}")
        return self

    def factor(self, name: str, nominal: float = 1.0) -> float:
        """1-sigma (RMS about ``nominal``) of a factor prior; 0 when exactly known."""
        prior = getattr(self, name)
        return 0.0 if prior is None else prior.rms_about(nominal, factor=True)

    def offset(self, name: str) -> float:
        """1-sigma (RMS about 0) of an offset prior; 0 when exactly known."""
        prior = getattr(self, name)
        return 0.0 if prior is None else prior.rms_about(0.0)
