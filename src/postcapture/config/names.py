"""Names the scenario schema accepts for its enumerated settings, in a module that imports nothing.

The command line offers exactly these as its choices (``simulate --integrator``, ``--variant``,
``--profile``), and builds its parser without importing the schema itself (pydantic), so that a bad
option is refused within a fraction of a second.
"""

__all__ = ["INTEGRATORS", "VARIANTS", "PROFILES", "MAX_SEGMENTS"]

INTEGRATORS = ("sdirk4", "sdirk3", "sdirk2", "rk4")
"""Integrators of the plant (``[simulation] integrator``, the truth's, and ``[estimation] integrator``, the filters')."""

VARIANTS = ("flexible", "stiff", "rigid")
"""Model variants: the flexible model, every spring at 1e7 N m/rad, every joint locked."""

PROFILES = ("reference", "realistic")
"""Sensor profiles and tunings (``[estimation.sensors.<profile>]``, ``[estimation.tuning.<profile>]``)."""

MAX_SEGMENTS = 1000
"""Most segments a panel may be cut into (scenario files and ``Panel.with_segments`` alike)."""
