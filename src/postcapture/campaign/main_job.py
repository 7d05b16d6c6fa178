"""The main job: truth, sensors, the reference's four dual schemes and the joint EKF, metrics, results.

One truth (the flexible model) and one set of measurements serve every case, as do the initial
attitude error (drawn from the filters' P0) and the initial mass error; the cases run in parallel
worker processes. The Cramer-Rao bound of the mass is computed on the same trajectory and noise.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from postcapture.campaign.cases import CASES, DEFAULT_CASES, attitude_P0, dual_config, gyro_sample_sigma, joint_tuning
from postcapture.campaign.metrics import ARCSEC, case_metrics
from postcapture.campaign.pool import run_jobs
from postcapture.campaign.sensing import measure_all, resolve_profile
from postcapture.config.schema import Scenario
from postcapture.core import rotations as rot
from postcapture.core.errors import ScenarioError, Problem
from postcapture.core.farrenkopf import farrenkopf_steady_state
from postcapture.dynamics.build import build_system
from postcapture.dynamics.process_model import NativeProcessModel
from postcapture.dynamics.simulate import simulate

__all__ = ["CaseOutput", "MainJobResult", "run_main_job", "initial_state_and_sensitivity"]


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

    def summary(self) -> dict:
        """The JSON the CLI prints: ``{"cases": {name: {...}}, "wall_s": ...}`` plus context."""
        return {
            "scenario": self.scenario,
            "profile": self.profile,
            "plant": self.plant,
            "duration_s": self.duration_s,
            "true_mass_kg": self.true_mass,
            "initial_mass_kg": self.initial_mass,
            "seed": self.seed,
            "noise": self.noise,
            "crlb_mass_kg": self.crlb.as_dict() if self.crlb is not None else None,
            "farrenkopf": self.farrenkopf,
            "cases": {name: c.metrics for name, c in self.cases.items()},
            "truth_wall_s": self.truth_wall_s,
            "wall_s": self.wall_s,
        }


def _run_case(job: dict, progress=None):
    """Worker: build the case's own plant copy and run its filter (top level, so it pickles)."""
    from postcapture.estimation.dual import run_dual
    from postcapture.estimation.joint import run_joint

    scenario = Scenario.model_validate(job["scenario"])
    spec = CASES[job["case"]]
    system = build_system(scenario, spec.variant)
    native = NativeProcessModel(system, scenario.simulation.step, scenario.simulation.integrator, name=spec.name)
    plant = job.get("plant", "native")
    if plant == "native":
        model = native
        x0, S0 = initial_state_and_sensitivity(model, job["theta0"])
    else:
        from postcapture.fmi import FMUProcessModel

        model = FMUProcessModel(plant[len("fmu:"):], mapping=job.get("mapping"), name=spec.name)
        model.mass = job["theta0"]
        if model.nx == native.nx and model.n == native.n:  # one of ours: same state layout as the native plant
            x0, S0 = initial_state_and_sensitivity(native, job["theta0"])
        else:  # another tool's FMU: its own start values, no initial sensitivity
            x0, S0 = model.initial_state(), np.zeros(model.n)
    q0 = rot.box_plus(job["q_true0"], job["dq0"])
    kwargs = dict(x0=x0, theta0=job["theta0"], t_grid=job["t_grid"], S0=S0, q0_BN=q0, raise_on_divergence=False,
                  progress=progress)
    if spec.scheme == "dual":
        cfg = dual_config(spec, job["profile"], job["profile_name"], scenario.n_arm)
        result = run_dual(model, job["sensors"], cfg, **kwargs)
    else:
        result = run_joint(model, job["sensors"], joint_tuning(job["profile"], job["profile_name"], scenario.n_arm),
                           name=spec.name, **kwargs)
    return spec.name, result


def _run_crlb(job: dict, progress=None):
    from postcapture.estimation.crlb import mass_crlb

    scenario = Scenario.model_validate(job["scenario"])
    model = NativeProcessModel(build_system(scenario), scenario.simulation.step, scenario.simulation.integrator)
    x0, S0 = initial_state_and_sensitivity(model, model.mass)
    p = job["profile"]
    return "crlb", mass_crlb(model, x0, S0, job["t_grid"], R_star=p.star_tracker.covariance(),
                             sigma_gyro=gyro_sample_sigma(p), sigma_accel=p.accelerometer.sigma, sigma_joint=p.joints.sigma,
                             progress=progress)


def run_main_job(
    scenario: Scenario,
    *,
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
    """Run the main job on a scenario.

    Parameters
    ----------
    scenario : Scenario
    profile : {"reference", "realistic"}
        Sensor profile and tuning policy (see :mod:`postcapture.campaign.cases`).
    duration : float, optional
        Seconds (default: the scenario's).
    cases : sequence of str
        Case names among :data:`postcapture.campaign.cases.CASES`.
    initial_mass_error : float, optional
        Added to the true mass to start the mass estimates (default: the scenario's, -100 kg).
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
    """
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        raise ScenarioError([Problem("cases", f"names among {', '.join(CASES)}", ", ".join(unknown))])
    if profile not in ("reference", "realistic"):
        raise ScenarioError([Problem("profile", "reference or realistic", repr(profile))])
    if scenario.target is None:
        raise ScenarioError([Problem("target", "a target whose mass to estimate", "none")])
    if plant != "native" and not plant.startswith("fmu:"):
        raise ScenarioError([Problem("plant", "native or fmu:PATH", repr(plant))])
    wall0 = time.perf_counter()
    est = scenario.estimation
    seed = est.seed if seed is None else int(seed)
    dm0 = est.initial_mass_error if initial_mass_error is None else float(initial_mass_error)
    if abs(scenario.simulation.sample_period - est.filter_step) > 1e-12 or abs(scenario.simulation.step - est.filter_step) > 1e-12:
        raise ScenarioError([Problem("estimation.filter_step", "equal to simulation.step and sample_period",
                                     f"{est.filter_step} (step {scenario.simulation.step}, samples {scenario.simulation.sample_period})")])

    def tell(msg, frac):
        if progress is not None:
            progress(msg, frac)

    tell("truth simulation", 0.0)
    t0 = time.perf_counter()
    truth = simulate(scenario, duration=duration, progress=lambda f: tell("truth simulation", f))
    truth_wall = time.perf_counter() - t0
    rng = np.random.default_rng(seed)
    sensor_profile = resolve_profile(scenario, profile)
    sensors = measure_all(truth, sensor_profile, rng)
    P0 = attitude_P0(sensor_profile, profile)
    dq0 = np.linalg.cholesky(P0) @ rng.standard_normal(3)
    m_true = float(scenario.target.mass)
    theta0 = m_true + dm0
    base = {"scenario": scenario.model_dump(), "t_grid": truth.t, "profile": sensor_profile, "profile_name": profile,
            "sensors": sensors, "theta0": theta0, "q_true0": truth["q_BN"][:, 0], "dq0": dq0,
            "plant": plant, "mapping": mapping}
    jobs = [(_run_case, {**base, "case": c}, c) for c in cases]
    if crlb:
        jobs.append((_run_crlb, base, "crlb"))
    outputs = run_jobs(jobs, workers=workers, on_progress=tell, on_done=lambda name, done, total: tell(name, 1.0))
    res = MainJobResult(scenario.name, profile, float(truth.t[-1] - truth.t[0]), m_true, theta0, seed, truth,
                        truth_wall_s=truth_wall, plant=plant)
    res.crlb = outputs.pop("crlb", None)
    for name in cases:
        res.cases[name] = CaseOutput(name, outputs[name], case_metrics(outputs[name], truth["q_BN"], m_true))
    st = sensor_profile.star_tracker
    bound = [farrenkopf_steady_state(s, sensor_profile.gyro.sigma_v, sensor_profile.gyro.sigma_u, 1.0 / st.rate)
             for s in (st.sigma_cross, st.sigma_cross, st.sigma_roll)]
    res.farrenkopf = {"axes": "star-tracker cross, cross, boresight (after update)",
                      "bound_arcsec": [float(b.attitude_post / ARCSEC) for b in bound]}
    axes = st.sensor_axes_B()  # columns: e1, e2, boresight (body components)
    for name, case in res.cases.items():
        if CASES[name].attitude != "mekf":
            continue
        hist = case.result.attitude
        steady = hist.t >= hist.t[0] + 0.5 * (hist.t[-1] - hist.t[0])
        e_B = rot.box_minus(truth["q_BN"][:, steady], hist.q_BN[:, steady])
        rms = np.sqrt(np.mean((axes.T @ e_B) ** 2, axis=1)) / ARCSEC
        res.farrenkopf[name] = {"empirical_arcsec": rms.tolist(),
                                "ratio": (rms / np.array(res.farrenkopf["bound_arcsec"])).tolist()}
    res.noise = {
        "star_tracker_cross_arcsec": st.sigma_cross / ARCSEC,
        "star_tracker_roll_arcsec": st.sigma_roll / ARCSEC,
        "gyro_arw_rad_sqrt_s": sensor_profile.gyro.sigma_v,
        "gyro_bias_walk_rad_s15": sensor_profile.gyro.sigma_u,
        "accelerometer_m_s2": sensor_profile.accelerometer.sigma,
        "accelerometer_bias_m_s2": float(np.max(np.abs(sensor_profile.accelerometer.bias_B))),
        "joint_acceleration_rad_s2": sensor_profile.joints.sigma,
        "rate_hz": st.rate,
    }
    res.wall_s = time.perf_counter() - wall0
    return res
