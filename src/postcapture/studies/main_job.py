"""The main job: truth, sensors, the reference's four dual schemes and the joint EKF, metrics, results.

The truth (by default the nominal scenario; or another scenario file, or a draw from the declared
priors) is simulated first; one set of measurements from it serves every case, as do the initial
attitude error (drawn from the filters' P0) and the initial mass estimate (the nominal mass plus the
initial error). Every filter is built from the nominal scenario. The cases run in parallel worker
processes. The Cramer-Rao bound of the mass is computed on the truth's own model and noise.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from postcapture.studies.cases import CASES, DEFAULT_CASES, dual_config, filter_noise
from postcapture.studies.metrics import ARCSEC, case_metrics
from postcapture.studies.pool import run_jobs
from postcapture.studies.sensing import measure_all
from postcapture.studies.setup import RunPlan, plan_run
from postcapture.config.schema import Scenario, orbit_mean_motion
from postcapture.core import rotations as rot
from postcapture.core.errors import CovarianceError, DomainError, FilterDivergenceError, SimulationError
from postcapture.core.farrenkopf import farrenkopf_steady_state
from postcapture.dynamics.build import build_system
from postcapture.dynamics.process_model import NativeProcessModel
from postcapture.dynamics.simulate import simulate
from postcapture.dynamics.truth import TruthModel

__all__ = ["CaseOutput", "MainJobResult", "run_main_job", "initial_state_and_sensitivity", "simulate_truth",
           "draw_sensors", "run_case"]

logger = logging.getLogger(__name__)


def initial_state_and_sensitivity(model, mass: float, dm: float = 1.0):
    """A plant copy's initial state at ``mass`` and its derivative with respect to the mass.

    The initial state follows from the scenario's initial conditions (attitude, rates, relaxed
    joints, centre of mass at rest at the origin), which place the chaser by the mass distribution:
    a mass error is also an initial-state error. The derivative is a central difference of that
    setup step (not of any dynamics), once per run.
    """
    model.mass = mass + dm
    xp = model.initial_state()
    model.mass = mass - dm
    xm = model.initial_state()
    model.mass = mass
    return model.initial_state(), model.local(xp, xm) / (2.0 * dm)


@dataclass
class CaseOutput:
    """One case's histories (a DualResult) and metrics."""

    name: str
    result: object
    metrics: dict


@dataclass
class MainJobResult:
    """Everything the main job produced."""

    scenario: str
    profile: str
    duration_s: float
    true_mass: float
    initial_mass: float
    seed: int
    truth: object
    cases: dict = field(default_factory=dict)
    crlb: object = None
    farrenkopf: dict | None = None
    noise: dict = field(default_factory=dict)
    wall_s: float = 0.0
    truth_wall_s: float = 0.0
    plant: str = "native"
    nominal_mass: float = float("nan")
    truth_info: dict = field(default_factory=dict)
    sensors: object = None  # the recorded measurements every case read (results.nc keeps them)
    scenario_model: object = None  # the nominal scenario (its TOML goes into the files' provenance)

    def summary(self) -> dict:
        """The JSON the CLI prints: ``{"cases": {name: {...}}, "truth": {...}, "wall_s": ...}`` plus context."""
        return {
            "scenario": self.scenario,
            "profile": self.profile,
            "plant": self.plant,
            "duration_s": self.duration_s,
            "true_mass_kg": self.true_mass,
            "nominal_mass_kg": self.nominal_mass,
            "initial_mass_kg": self.initial_mass,
            "seed": self.seed,
            "truth": self.truth_info,
            "noise": self.noise,
            "crlb_mass_kg": self.crlb["nuisance"].as_dict() if self.crlb is not None else None,
            "crlb_known_model_mass_kg": self.crlb["known_model"].as_dict() if self.crlb is not None else None,
            "crlb_parameters_only_mass_kg": self.crlb["parameters"].as_dict() if self.crlb is not None else None,
            "farrenkopf": self.farrenkopf,
            "cases": {name: c.metrics for name, c in self.cases.items()},
            "truth_wall_s": self.truth_wall_s,
            "wall_s": self.wall_s,
        }


def simulate_truth(plan: RunPlan, progress: Callable[[float], None] | None = None):
    """The truth trajectory of a plan (its own scenario, discretisation and parameters)."""
    truth = plan.truth
    return simulate(truth.scenario, duration=plan.duration, parameters=truth.parameters, progress=progress)


def draw_sensors(plan: RunPlan, traj, seed: int):
    """The truth's sensor records under the plan's faults, and the filters' initial attitude error (rad, 3)."""
    rng = np.random.default_rng(seed)
    sensors = measure_all(traj, plan.truth_profile, rng, plan.faults,
                          accelerometer_position=plan.truth.scenario.chaser.accelerometer_position,
                          mean_motion=orbit_mean_motion(plan.truth.scenario, "truth"))
    dq0 = np.linalg.cholesky(plan.tuning.attitude_P0) @ rng.standard_normal(3)
    return sensors, dq0


def run_case(plan: RunPlan, case: str, sensors, q0_true, dq0, progress=None):
    """Run one case of a plan on recorded sensors; returns its result (a DualResult or a SchemeResult).

    A case whose filters cannot go on (their plant copy fails even after re-initialising) ends there: its
    result carries ``success=False`` and the cause, and the other cases are not affected.
    """
    try:
        return _run_case_unguarded(plan, case, sensors, q0_true, dq0, progress)
    except (SimulationError, FilterDivergenceError, CovarianceError, DomainError) as exc:
        logger.error("case %s failed: %s", case, exc)
        return _failed_result(case, plan.t_grid, str(exc))


def _failed_result(case: str, t_grid, message: str):
    from postcapture.estimation.dual import DualResult
    from postcapture.estimation.history import EstimateHistory, StepFlag

    n = t_grid.size
    nan = np.full(n, np.nan)
    history = EstimateHistory(case, t_grid, np.full((4, n), np.nan), np.full((3, 3, n), np.nan), nan.copy(),
                              np.full(n, int(StepFlag.DIVERGED), dtype=np.uint8), ("dtheta_x", "dtheta_y", "dtheta_z"),
                              success=False, status=-1, message=f"failed: {message}")
    return DualResult(history, nan.copy(), nan.copy(), nan.copy(), 0.0, {})


def _run_case_unguarded(plan: RunPlan, case: str, sensors, q0_true, dq0, progress=None):
    scenario = plan.scenario
    spec = CASES[case]
    theta0 = plan.initial_mass
    est = scenario.estimation
    native = NativeProcessModel.for_filters(scenario, variant=spec.variant, name=spec.name)
    q0 = rot.box_plus(np.asarray(q0_true, dtype=float), dq0)
    t_grid = plan.t_grid
    if spec.scheme in ("dual", "joint"):
        return _run_recommended(plan, spec, native, sensors, q0, progress)
    from postcapture.estimation.dual import run_dual

    if plan.plant == "native":
        model = native
        x0, S0 = initial_state_and_sensitivity(model, theta0)
    else:
        from postcapture.fmi import FMUProcessModel

        model = FMUProcessModel(plan.plant[len("fmu:"):], mapping=plan.mapping, name=spec.name)
        model.mass = theta0
        if model.nx == native.nx and model.n == native.n:  # one of ours: same state layout as the native plant
            x0, S0 = initial_state_and_sensitivity(native, theta0)
        else:  # another tool's FMU: its own start values, no initial sensitivity
            x0, S0 = model.initial_state(), np.zeros(model.n)
    cfg = dual_config(spec, plan.filter_profile, plan.profile_name, plan.tuning, scenario.n_arm, theta0)
    return run_dual(model, sensors, cfg, x0=x0, theta0=theta0, t_grid=t_grid, S0=S0, q0_BN=q0,
                    raise_on_divergence=False, progress=progress)


def _run_recommended(plan: RunPlan, spec, model, sensors, q0, progress):
    """The recommended dual or joint scheme (:mod:`postcapture.estimation.schemes`)."""
    from postcapture.studies.robust import build_augmented, with_discretisation_bias
    from postcapture.estimation.mekf import MEKF
    from postcapture.estimation.schemes import run_dual_scheme, run_joint_scheme

    prof, tun = plan.filter_profile, plan.tuning
    R = filter_noise(prof, tun, plan.scenario.n_arm)
    panel_mass = sum(p.mass for p in plan.scenario.target.panels)
    if spec.scheme == "joint":
        filt = build_augmented(plan, model, q0, name=spec.name)
        result = run_joint_scheme(filt, sensors, plan.t_grid, R=R, panel_mass=panel_mass, progress=progress,
                                  name=spec.name)
    else:
        cfg = dual_config(spec, prof, plan.profile_name, tun, plan.scenario.n_arm, plan.initial_mass)
        mekf = MEKF(cfg.mekf, q0, cfg.mekf_P0, t0=plan.t_grid[0])
        filt = build_augmented(plan, model, q0, name=f"{spec.name}/parameters")
        result = run_dual_scheme(mekf, filt, sensors, plan.t_grid, R=R, panel_mass=panel_mass, progress=progress,
                                 name=spec.name)
    return with_discretisation_bias(result, tun.discretisation_bias)


STEADY_RATIO = 1.2
"""The filter is taken to be in steady state where its own sigma is within this factor of Farrenkopf's bound."""


def _farrenkopf_comparison(hist, q_true, star, bound_arcsec) -> dict:
    """Steady error per star-tracker axis against Farrenkopf's bound, where the filter has reached it.

    The filter is in steady state where its own 1-sigma (from its covariance) is within ``STEADY_RATIO`` of
    the bound on every axis; the comparison uses the last quarter of the run if it is, and otherwise says
    that the run is too short and gives the filter's own sigma at the end beside the bound (the
    covariance-predicted transient).
    """
    axes = star.sensor_axes_B()  # columns: e1, e2, boresight (body components)
    P = np.einsum("ai,ijk,jb->abk", axes.T, hist.P[:3, :3], axes)
    own = np.sqrt(np.einsum("iik->ik", P)) / ARCSEC  # (3, n) the filter's own sigma per axis
    window = hist.t >= hist.t[0] + 0.75 * (hist.t[-1] - hist.t[0])
    e = axes.T @ rot.box_minus(q_true[:, window], hist.q_BN[:, window]) / ARCSEC
    rms = np.sqrt(np.mean(e**2, axis=1))
    own_end = np.sqrt(np.mean(own[:, window] ** 2, axis=1))
    steady = bool(np.all(own_end <= STEADY_RATIO * bound_arcsec))
    return {"steady": steady, "empirical_arcsec": rms.tolist(), "own_sigma_arcsec": own_end.tolist(),
            "ratio": (rms / bound_arcsec).tolist() if steady else None,
            "own_sigma_over_bound": (own_end / bound_arcsec).tolist(),
            "error_over_own_sigma": (rms / own_end).tolist()}


def _run_case(job: dict, progress=None):
    """Worker: one case (top level, so it pickles)."""
    return job["case"], run_case(job["plan"], job["case"], job["sensors"], job["q_true0"], job["dq0"], progress)


def _run_crlb(job: dict, progress=None):
    from postcapture.studies.robust import mass_bounds

    return "crlb", mass_bounds(job["plan"], progress)


def run_main_job(
    scenario: Scenario,
    *,
    truth: TruthModel | None = None,
    profile: str = "reference",
    duration: float | None = None,
    cases=DEFAULT_CASES,
    initial_mass_error: float | None = None,
    seed: int | None = None,
    workers: int = 2,
    crlb: bool = True,
    plant: str = "native",
    mapping: str | None = None,
    progress: Callable[[str, float], None] | None = None,
) -> MainJobResult:
    """Run the main job: the filters on the nominal scenario, against a truth.

    Parameters
    ----------
    scenario : Scenario
        The nominal scenario: every filter's model.
    truth : TruthModel, optional
        The simulated world (:mod:`postcapture.dynamics.truth`); the nominal scenario by default.
    profile : {"reference", "realistic"}
        Sensor profile and tuning policy (see :mod:`postcapture.studies.tuning`).
    duration : float, optional
        Seconds (default: the scenario's).
    cases : sequence of str
        Case names among :data:`postcapture.studies.cases.CASES`.
    initial_mass_error : float, optional
        Added to the nominal mass to start the mass estimates (default: the scenario's, -100 kg).
    seed : int, optional
        Seed of the sensor noise and initial attitude errors (default: the scenario's).
    workers : int
        Worker processes for the cases (1 runs them in this process).
    crlb : bool
        Also compute the mass Cramer-Rao bound (one more pass of step Jacobians).
    plant : str
        The filters' process model: ``"native"`` (Pinocchio) or ``"fmu:PATH"`` (any co-simulation FMU;
        every case then runs on that FMU, whatever its case name's variant).
    mapping : str, optional
        The FMU's mapping TOML (default: the one inside the FMU or next to it).
    progress : callable(task, fraction), optional
        Called as each task advances: ``task`` is ``"truth simulation"``, a case name or ``"crlb"``,
        ``fraction`` the part of that task done (0 to 1; 1 when it ends).

    Raises
    ------
    ScenarioError
        For any bad setting, before anything is simulated (see :func:`postcapture.studies.setup.plan_run`).
    """
    plan = plan_run(scenario, truth=truth, profile=profile, duration=duration, cases=tuple(cases),
                    initial_mass_error=initial_mass_error, seed=seed, plant=plant, mapping=mapping)
    if crlb or any(CASES[c].scheme in ("dual", "joint") for c in plan.cases):
        from postcapture.studies.robust import with_model_noise

        plan = with_model_noise(plan)
    wall0 = time.perf_counter()

    def tell(msg, frac):
        if progress is not None:
            progress(msg, frac)

    tell("truth simulation", 0.0)
    t0 = time.perf_counter()
    traj = simulate_truth(plan, progress=lambda f: tell("truth simulation", f))
    truth_wall = time.perf_counter() - t0
    sensors, dq0 = draw_sensors(plan, traj, plan.seed)
    base = {"plan": plan, "sensors": sensors, "q_true0": traj["q_BN"][:, 0], "dq0": dq0}
    jobs = [(_run_case, {**base, "case": c}, c) for c in plan.cases]
    if crlb:  # the longest job first, so that it does not start last on one worker while the other idles
        jobs.insert(0, (_run_crlb, base, "crlb"))
    outputs = run_jobs(jobs, workers=workers, on_progress=tell, on_done=lambda name, done, total: tell(name, 1.0))
    truth_info = plan.truth.describe(scenario)
    m_true = truth_info["target_mass"]
    res = MainJobResult(scenario.name, plan.profile_name, float(traj.t[-1] - traj.t[0]), m_true, plan.initial_mass,
                        plan.seed, traj, truth_wall_s=truth_wall, plant=plan.plant, nominal_mass=plan.nominal_mass,
                        truth_info=truth_info, sensors=sensors, scenario_model=scenario)
    res.crlb = outputs.pop("crlb", None)
    for name in plan.cases:
        res.cases[name] = CaseOutput(name, outputs[name], case_metrics(outputs[name], traj["q_BN"], m_true))
    sensor_profile = plan.truth_profile
    st = sensor_profile.star_tracker
    bound = [farrenkopf_steady_state(s, sensor_profile.gyro.sigma_v, sensor_profile.gyro.sigma_u, 1.0 / st.rate)
             for s in (st.sigma_cross, st.sigma_cross, st.sigma_roll)]
    res.farrenkopf = {"axes": "star-tracker cross, cross, boresight (after update)",
                      "bound_arcsec": [float(b.attitude_post / ARCSEC) for b in bound]}
    for name, case in res.cases.items():
        if CASES[name].attitude == "mekf":
            res.farrenkopf[name] = _farrenkopf_comparison(case.result.attitude, traj["q_BN"], st,
                                                          np.array(res.farrenkopf["bound_arcsec"]))
    res.noise = {
        "star_tracker_cross_arcsec": st.sigma_cross / ARCSEC,
        "star_tracker_roll_arcsec": st.sigma_roll / ARCSEC,
        "gyro_arw_rad_sqrt_s": sensor_profile.gyro.sigma_v,
        "gyro_bias_walk_rad_s15": sensor_profile.gyro.sigma_u,
        "accelerometer_m_s2": sensor_profile.accelerometer.sigma,
        "accelerometer_bias_m_s2": float(np.max(np.abs(sensor_profile.accelerometer.bias_B))),
        "encoder_rad": sensor_profile.joints.sample_sigma,
        "rate_hz": st.rate,
    }
    res.wall_s = time.perf_counter() - wall0
    return res
