"""The scenario: schema, TOML loading with full validation, and the embedded default scenarios.

The names below are imported on first use, so that ``postcapture.config.names`` (the schema's choices,
which the command line reads to build its parser) costs nothing to import.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

__all__ = [
    "Scenario",
    "Chaser",
    "Target",
    "Arm",
    "ArmJoint",
    "Panel",
    "InitialState",
    "Simulation",
    "load_scenario",
    "scenario_from_dict",
    "builtin_scenarios",
]

_LAZY = {name: "postcapture.config.schema" for name in __all__[:8]}
_LAZY.update({name: "postcapture.config.loader" for name in __all__[8:]})

if TYPE_CHECKING:  # pragma: no cover
    from postcapture.config.loader import builtin_scenarios, load_scenario, scenario_from_dict
    from postcapture.config.schema import Arm, ArmJoint, Chaser, InitialState, Panel, Scenario, Simulation, Target


def __getattr__(name: str):
    """Import the public names on first use."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'postcapture.config' has no attribute {name!r}")
