"""One run's plan: every setting resolved and checked before the truth is simulated.

The filters always use the nominal scenario; the truth (:class:`~postcapture.dynamics.truth.TruthModel`)
may differ from it. The plan holds what both sides need: the sensor profile the truth's sensors follow
(its biases drawn with the truth when declared uncertain), the tunings the filters derive from the
nominal scenario, the initial mass estimate, the cases, and the fault schedule.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from postcapture.studies.cases import CASES
from postcapture.studies.sensing import resolve_profile
from postcapture.studies.tuning import ResolvedTuning, resolve_tuning
from postcapture.config.schema import Scenario, fault_problems
from postcapture.core.errors import Problem, ScenarioError
from postcapture.dynamics.truth import TruthModel, nominal_truth
from postcapture.sensors.profiles import SensorProfile

__all__ = ["RunPlan", "plan_run", "PROFILES"]

PROFILES = ("reference", "realistic")
MIN_FILTER_STEPS = 10


@dataclass(frozen=True)
class RunPlan:
    """Everything a run needs, resolved (see :func:`plan_run`)."""

    scenario: Scenario  # nominal: the filters' model
    truth: TruthModel
    profile_name: str
    truth_profile: SensorProfile  # what the truth's sensors do (drawn biases included)
    filter_profile: SensorProfile  # what the filters are told about the sensors (nominal)
    tuning: ResolvedTuning
    duration: float
    cases: tuple[str, ...]
    nominal_mass: float
    initial_mass: float
    seed: int
    plant: str = "native"
    mapping: str | None = None
    faults: tuple = ()  # the truth's sensor faults (the filters are not told)

    @property
    def t_grid(self) -> np.ndarray:
        """Filter instants (s)."""
        dt = self.scenario.estimation.filter_step
        n = int(round(self.duration / dt))
        return np.array([k * dt for k in range(n + 1)])


def plan_run(
    scenario: Scenario,
    *,
    truth: TruthModel | None = None,
    profile: str = "reference",
    duration: float | None = None,
    cases=(),
    initial_mass_error: float | None = None,
    seed: int | None = None,
    plant: str = "native",
    mapping: str | None = None,
) -> RunPlan:
    """Check every setting of a run and resolve it; nothing is simulated.

    Raises
    ------
    ScenarioError
        Listing every problem: unknown cases or profile, no target, a plant that is neither native nor
        an FMU, a filter step off the simulation grid, a run too short, faults outside the run, sigmoid
        bounds that do not hold the initial estimate.
    """
    problems: list[Problem] = []
    bad = [c for c in cases if c not in CASES]
    if bad or not cases:
        problems.append(Problem("cases", f"names among {', '.join(CASES)}", ", ".join(bad) or "none"))
    if profile not in PROFILES:
        problems.append(Problem("profile", " or ".join(PROFILES), repr(profile)))
    if scenario.target is None:
        problems.append(Problem("target", "a target whose mass to estimate", "none"))
    if plant != "native" and not (plant.startswith("fmu:") and len(plant) > 4):
        problems.append(Problem("plant", "native or fmu:PATH", repr(plant)))
    recommended = [c for c in cases if c in CASES and CASES[c].scheme in ("dual", "joint")]
    if plant != "native" and recommended:
        problems.append(Problem("cases", "with an FMU plant, the reference's dual schemes only: the recommended "
                                         "schemes need the native model's parameter Jacobians", ", ".join(recommended)))
    est, sim = scenario.estimation, scenario.simulation
    if abs(sim.sample_period - est.filter_step) > 1e-12:
        problems.append(Problem("estimation.filter_step", "equal to simulation.sample_period (the sensors sample "
                                "the truth at the filters' cycle)", f"{est.filter_step} (samples {sim.sample_period})"))
    T = float(sim.duration if duration is None else duration)
    if not T >= MIN_FILTER_STEPS * est.filter_step:
        problems.append(Problem("duration", f"at least {MIN_FILTER_STEPS} filter steps "
                                            f"({MIN_FILTER_STEPS * est.filter_step:g} s)", f"{T:g} s"))
    problems += [Problem(*p) for p in fault_problems(scenario.faults, T)]
    dm0 = est.initial_mass_error if initial_mass_error is None else float(initial_mass_error)
    if not np.isfinite(dm0):
        problems.append(Problem("initial_mass_error", "a finite number (kg)", repr(dm0)))
    if problems:
        raise ScenarioError(problems)
    truth = nominal_truth(scenario) if truth is None else truth
    # the faults are the truth's sensors': a truth scenario file carries its own; the nominal scenario's are
    # refused beside a truth scenario that does not declare them (they would be ignored without a word)
    faults = truth.scenario.faults
    if truth.source.startswith("scenario") and scenario.faults and scenario.faults != faults:
        raise ScenarioError([Problem("faults", "faults declared in the truth scenario (they belong to the truth's "
                                               "sensors): move them there", f"{len(scenario.faults)} in the nominal "
                                               f"scenario, {len(faults)} in the truth scenario")])
    if faults is not scenario.faults:
        fault_errors = [Problem(f"truth scenario: {path}", expected, found)
                        for path, expected, found in fault_problems(faults, T)]
        if fault_errors:
            raise ScenarioError(fault_errors)
    m_nom = float(scenario.target.mass)
    m0 = m_nom + dm0
    panels = sum(p.mass for p in scenario.target.panels)
    if not m0 > panels:
        raise ScenarioError([Problem("initial_mass_error", f"an initial mass above the target's panels ({panels:g} kg)",
                                     f"{dm0:g} kg, i.e. {m0:g} kg")])
    filter_profile = resolve_profile(scenario, profile)
    truth_profile = filter_profile
    gyro_changes = {key: np.asarray(value) for key, value in (("initial_bias_B", truth.gyro_bias_B),
                                                               ("scale_factor", truth.gyro_scale_factor),
                                                               ("misalignment", truth.gyro_misalignment))
                    if value is not None}
    if gyro_changes:
        truth_profile = dataclasses.replace(truth_profile, gyro=dataclasses.replace(truth_profile.gyro, **gyro_changes))
    if truth.accel_bias_B is not None:
        truth_profile = dataclasses.replace(
            truth_profile,
            accelerometer=dataclasses.replace(truth_profile.accelerometer, bias_B=np.asarray(truth.accel_bias_B)))
    tuning = resolve_tuning(scenario, profile, filter_profile, initial_mass=m0)
    return RunPlan(scenario, truth, profile, truth_profile, filter_profile, tuning, T, tuple(cases), m_nom, m0,
                   est.seed if seed is None else int(seed), plant, mapping, faults=tuple(faults))
