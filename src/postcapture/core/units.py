"""Conversion factors from the non-SI units that sensor datasheets and reports use, to SI.

Everything inside postcapture is SI (rad, s, m, kg). Multiply a datasheet value by one of these
factors at the boundary where it enters (a profile definition, a scenario loader) and divide by it
where a value leaves for a human (a table in arcsec). This module is the one place where those
factors are written down.

Examples
--------
>>> from postcapture.core.units import ARCSEC, DEG_PER_HOUR
>>> f"{2.0 * ARCSEC:.4e}"  # 2 arcsec in rad
'9.6963e-06'
>>> f"{0.01 * DEG_PER_HOUR:.4e}"  # 0.01 deg/h in rad/s
'4.8481e-08'
"""

from __future__ import annotations

import math

__all__ = [
    "DEG",
    "ARCSEC",
    "HOUR",
    "DEG_PER_HOUR",
    "DEG_PER_SQRT_HOUR",
    "STANDARD_GRAVITY",
    "MICRO_G",
]

DEG = math.pi / 180.0
"""One degree (rad)."""

ARCSEC = DEG / 3600.0
"""One arcsecond (rad), about 4.848e-6 rad."""

HOUR = 3600.0
"""One hour (s)."""

DEG_PER_HOUR = DEG / HOUR
"""One deg/h (rad/s): the unit of gyro bias stability on datasheets."""

DEG_PER_SQRT_HOUR = DEG / math.sqrt(HOUR)
"""One deg/sqrt(h) (rad/sqrt(s)): the unit of gyro angle random walk on datasheets."""

STANDARD_GRAVITY = 9.80665
"""Standard gravity g0 (m/s^2)."""

MICRO_G = 1e-6 * STANDARD_GRAVITY
"""One micro-g (m/s^2): the unit of accelerometer bias on datasheets."""
