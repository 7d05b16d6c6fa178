"""The scenario: schema, TOML loading with full validation, and the embedded default scenarios."""

from postcapture.config.loader import builtin_scenarios, load_scenario, scenario_from_dict
from postcapture.config.schema import Arm, ArmJoint, Chaser, InitialState, Panel, Scenario, Simulation, Target

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
