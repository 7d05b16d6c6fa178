"""The recommended schemes' filters, built from a run plan: what they estimate, consider, and assume.

Groups (:mod:`postcapture.estimation.parameters`) are estimated or considered as the scenario's
``[estimation.tuning.<profile>]`` says (``estimate``, ``consider``); by default every group the
``[uncertainty]`` declares uncertain is estimated, except the dampers, which are considered (their
effect is small and slow to observe; estimating them buys little and costs states). A group that is
not declared uncertain is known exactly.

The prior of the filter's parameter coordinates is the declared prior itself, pushed through the
filter's own coordinates: the second moment of ``eta(draw) - eta0`` over draws from the priors
(:func:`~postcapture.dynamics.truth.draw_parameters`), with ``eta0`` the initial estimate (the nominal
parameters with the initial mass error). It covers both the spread of the truth and the declared
initial error, so the prior sigma means what it says in kg, m and kg m^2 wherever the estimate starts.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from postcapture.config.schema import orbit_mean_motion
from postcapture.core import rotations as rot

from postcapture.studies.setup import RunPlan
from postcapture.config.uncertainty import Prior
from postcapture.dynamics.parameters import dynamic_parameters, mass_properties
from postcapture.dynamics.truth import draw_parameters
from postcapture.estimation.augmented import AugmentedEKF, AugmentedTuning
from postcapture.estimation.crlb import MassCRLB
from postcapture.estimation.parameters import GROUPS, ParameterMap

__all__ = ["parameter_groups", "parameter_prior", "initial_state_sensitivity", "build_augmented", "mass_bounds",
           "derive_model_noise", "with_model_noise", "discretisation_bias", "with_discretisation_bias",
           "bound_with_model_error", "PRIOR_DRAWS"]

PRIOR_DRAWS = 4000
_PRIOR_SEED = 0x9E3779B9


def parameter_groups(plan: RunPlan) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The groups the recommended filters estimate and consider (see the module docstring)."""
    unc = plan.scenario.uncertainty
    declared = {
        "target": True,  # the mass is always uncertain: it is what the filters are for
        "panel_bending": unc.panel_bending is not None,
        "panel_torsion": unc.panel_torsion is not None,
        "panel_damping": unc.panel_damping is not None,
        "arm_stiffness": unc.arm_stiffness is not None,
        "arm_damping": unc.arm_damping is not None,
    }
    given = plan.scenario.estimation.tuning.get(plan.profile_name)
    if given is not None and given.estimate is not None:
        estimate = tuple(given.estimate)
    else:
        estimate = tuple(g for g in GROUPS if declared[g] and g not in ("panel_damping", "arm_damping"))
    if given is not None and given.consider is not None:
        consider = tuple(given.consider)
    else:
        consider = tuple(g for g in GROUPS if declared[g] and g not in estimate)
    return estimate, consider


def _with_mass_prior(scenario, sigma: float):
    """The scenario with a target-mass prior (the declared one, or ``sigma`` when none is declared)."""
    if scenario.uncertainty.target_mass is not None:
        return scenario
    unc = scenario.uncertainty.model_copy(update={"target_mass": Prior(sigma=sigma)})
    return scenario.model_copy(update={"uncertainty": unc})


def parameter_prior(plan: RunPlan, pmap: ParameterMap, draws: int = PRIOR_DRAWS, *,
                    initial_mass: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Initial coordinates ``eta0`` and their covariance from the declared priors (see the module docstring).

    ``initial_mass`` (kg) is the start of the estimate (the plan's by default; the nominal mass gives
    the prior itself, about the nominal parameters). The result depends only on the nominal scenario,
    the map and the initial mass (the draws have their own seed, not the run's), so a process computes it
    once and every run of a campaign with the same filters reuses it.
    """
    m0 = float(plan.initial_mass if initial_mass is None else initial_mass)
    scenario = _with_mass_prior(plan.scenario, plan.tuning.mass_prior_sigma)
    key = (scenario.model_dump_json(), pmap.model_names, pmap.p_nominal.tobytes(), pmap.groups, pmap.labels,
           m0, float(plan.nominal_mass), int(draws))
    if key not in _PRIOR_CACHE:
        if len(_PRIOR_CACHE) >= 8:
            _PRIOR_CACHE.pop(next(iter(_PRIOR_CACHE)))
        _PRIOR_CACHE[key] = _draw_prior(scenario, pmap, draws, m0 - plan.nominal_mass)
    eta0, P = _PRIOR_CACHE[key]
    return eta0.copy(), P.copy()


_PRIOR_CACHE: dict = {}


def _draw_prior(scenario, pmap: ParameterMap, draws: int, mass_offset: float):
    names = pmap.model_names
    p0 = pmap.p_nominal.copy()
    if "target.m" in names:
        hub = mass_properties(p0[:10])
        hub.mass += mass_offset
        p0[:10] = dynamic_parameters(hub)
    eta0 = pmap.from_model(p0)
    rng = np.random.default_rng(_PRIOR_SEED)
    D = np.empty((draws, pmap.size))
    for i in range(draws):
        p = pmap.p_nominal.copy()
        for name, value in draw_parameters(scenario, rng).items():
            p[names.index(name)] = value
        D[i] = pmap.from_model(p) - eta0
    P = D.T @ D / draws
    P += 1e-12 * np.trace(P) / max(pmap.size, 1) * np.eye(pmap.size)  # a prior on a curve is nearly singular
    return eta0, P


def initial_state_sensitivity(model) -> np.ndarray:
    """``d x0 / d p`` (n x n_p) of the model's initial state, by central differences of the set-up step.

    The initial state follows from the scenario's initial conditions through the mass distribution and
    the springs (relaxed deflections, the CoM at rest at the origin); steps of 1 kg, 1 kg m, 10 kg m^2 and
    1e-3 of a factor.
    """
    p0 = model.params
    S = np.zeros((model.n, p0.size))
    for j, name in enumerate(model.param_names):
        if name.startswith("target."):
            eps = 10.0 if name.startswith("target.I") else 1.0
        else:
            eps = 1e-3
        states = []
        for s in (+1.0, -1.0):
            p = p0.copy()
            p[j] += s * eps
            model.set_params(p)
            states.append(model.initial_state())
        S[:, j] = model.local(states[0], states[1]) / (2.0 * eps)
    model.set_params(p0)
    return S


def _rate_drift_walk(plan: RunPlan, min_time: float) -> float:
    """Random-walk variance per filter step that covers how far the filters' model and the declared truth
    take the chaser's body rates apart (both at nominal parameters, open loop, the whole manoeuvre)."""
    from postcapture.dynamics.simulate import simulate

    sc = plan.scenario
    n_seg = sc.uncertainty.truth_panel_segments
    finer_panels = n_seg is not None and any(p.segments != n_seg for _, p in sc.panels())
    horizon = max(plan.duration, sc.simulation.duration)
    est = sc.estimation
    filters = simulate(sc, duration=horizon, integrator=est.integrator, step=est.model_step, side="filters")
    truth = simulate(sc.with_panel_segments(n_seg) if finer_panels else sc, duration=horizon)
    steps = (filters.t - filters.t[0]) / est.filter_step
    late = filters.t >= min(min_time, 0.5 * horizon)
    drift = np.max(np.abs(truth["omega_BN_B"] - filters["omega_BN_B"]), axis=0)
    return float(np.max(drift[late] ** 2 / steps[late]))


_LINEARISATION_DRAWS = 6
_LINEARISATION_SEED = 0x5EED17
_LINEARISATION_EVERY = 10


def _linearisation_walk(plan: RunPlan, draws: int = _LINEARISATION_DRAWS,
                        every: int = _LINEARISATION_EVERY) -> float:
    """Variance per filter step of what the filters' first-order prediction misses over the declared prior:
    the second-order part of one step's body rates in the parameters, ``r = (F(x, p0 + d) + F(x, p0 - d)
    - 2 F(x, p0)) / 2``, averaged over ``draws`` prior draws ``d`` (a fixed seed) and over every
    ``every``-th step of the nominal trajectory (the filters' model, open loop)."""
    from postcapture.core.errors import DomainError
    from postcapture.dynamics.process_model import NativeProcessModel

    sc = plan.scenario
    dt = sc.estimation.filter_step
    model = NativeProcessModel.for_filters(sc)
    p0 = model.params
    rng = np.random.default_rng(_LINEARISATION_SEED)
    deltas = []
    for _ in range(draws):
        model.set_params(p0)
        model.update_params(draw_parameters(sc, rng))
        deltas.append(model.params - p0)
    model.set_params(p0)
    if not any(np.any(d) for d in deltas):
        return 0.0
    rate = slice(model.nq + 3, model.nq + 6)
    x = model.initial_state()
    n = int(round(max(plan.duration, sc.simulation.duration) / dt))
    total, count = 0.0, 0
    for i in range(n):
        t = i * dt
        x_next = model.predict(x, t, dt).x
        if i % every == 0:
            for d in deltas:
                scale = 1.0
                while True:  # a mirrored draw that is no body: a smaller step, the residual scaled back (quadratic)
                    try:
                        ends = []
                        for sign in (1.0, -1.0):
                            model.set_params(p0 + sign * scale * d)
                            ends.append(model.predict(x, t, dt).x[rate])
                        break
                    except DomainError:
                        scale *= 0.5
                        if scale < 1e-3:
                            raise
                model.set_params(p0)
                r = 0.5 * (ends[0] + ends[1] - 2.0 * x_next[rate]) / scale**2
                total += float(np.mean(r**2))
                count += 1
        x = x_next
    return total / max(count, 1)


def derive_model_noise(plan: RunPlan, *, min_time: float = 10.0) -> float:
    """Model-error process noise, per filter step on every plant velocity, from what the truth declares itself to be.

    Two parts, added (independent causes):

    - **What no parameter describes.** The filters' model has the nominal panel segments and its own
      integrator and step (``[estimation]``), and covers the orbit's gravity gradient unless it models it;
      the truth has ``truth_panel_segments`` and is integrated to its declared accuracy. Both are simulated
      open loop at the nominal parameters under the scenario's whole manoeuvre (its own duration, or the
      run's if longer: a shorter run gets the same noise), and the velocities get the random walk whose
      spread covers how far apart that takes the chaser's body rates (what the gyro reads):
      ``q = max_t |d omega(t)|^2 / (t / dt)`` over ``t >= min_time``.
    - **What the filters' linearisation misses over the prior** (:func:`_linearisation_walk`): the
      second-order part of one prediction step in the parameters, at the declared prior's spread. The
      first-order part is what the parameter states carry; the second is not, and it is what made the 2 t
      target's filters leave their 3 sigma (8.8 sigma on the mass at 15 s, with the first part alone, 3.2e-12
      per step) while the arm's sweeps start: 8.5e-11 there, 3.2e-10 on Envisat.

    The same variance on every velocity coordinate is the conservative choice. Noise given the structure of
    its cause (the whole stack turning faster or slower about its centre of mass, joints moving with the
    momentum kept) left the chaser's centre without a walk of its own and tightened the mass bound from 18.6
    to 7.7 kg, but over 10 dispersed converged truths the filters were then overconfident on the target's
    products of inertia (12 % of the components beyond 3 sigma, up to 5 sigma), at a final mass error RMS of
    18.9 kg against 20.3 kg here, where every component stays inside (README, "What the filters assume").
    """
    return _rate_drift_walk(plan, min_time) + _linearisation_walk(plan)


def with_model_noise(plan: RunPlan) -> RunPlan:
    """The plan with its model error derived: the model noise (:func:`derive_model_noise`) unless the
    scenario sets it, and the discretisation's bias of the parameters (:func:`discretisation_bias`).

    Both depend only on the nominal scenario, the profile, the run's grid and the code, not on the run's
    truth or noise: they are kept in the user cache (``derived/`` beside the compiled cores) under a key of
    all of these, so a second run of the same scenario does not derive them again (about 15 s of CPU on
    Envisat). A damaged or foreign cache file is derived again and replaced.
    """
    tuning = plan.tuning
    cached = _load_derived(plan)
    if cached is not None and tuning.model_noise is None and tuning.discretisation_bias is None:
        noise, bias = cached
        return dataclasses.replace(plan, tuning=dataclasses.replace(tuning, model_noise=noise,
                                                                    discretisation_bias=bias))
    declared = tuning.model_noise is not None
    if not declared:
        tuning = dataclasses.replace(tuning, model_noise=derive_model_noise(plan))
    if tuning.discretisation_bias is None:
        tuning = dataclasses.replace(tuning, discretisation_bias=discretisation_bias(
            dataclasses.replace(plan, tuning=tuning)))
        if not declared:
            _save_derived(plan, float(tuning.model_noise), tuning.discretisation_bias)
    return dataclasses.replace(plan, tuning=tuning)


_CODE_FINGERPRINT: list = []


def _derived_path(plan: RunPlan):
    """Where a plan's derived model error is kept: a key of the scenario (without its faults), profile, grid and
    the package's code."""
    import hashlib
    from importlib import resources

    from postcapture.dynamics.compiled import cache_dir

    if not _CODE_FINGERPRINT:
        h = hashlib.sha256()
        root = resources.files("postcapture")
        for sub in ("dynamics", "estimation", "sensors", "studies", "config", "core"):
            for f in sorted((root / sub).iterdir(), key=lambda x: x.name):
                if f.name.endswith(".py"):
                    h.update(f.name.encode() + f.read_bytes())
            csrc = root / sub / "csrc"
            if csrc.is_dir():
                for f in sorted(csrc.iterdir(), key=lambda x: x.name):
                    h.update(f.name.encode() + f.read_bytes())
        _CODE_FINGERPRINT.append(h.hexdigest())
    # the faults are left out: they act on the sensors, and the derivation reads fault-free, noise-free ones
    fault_free = plan.scenario.model_copy(update={"faults": ()})
    key = hashlib.sha256("|".join([fault_free.model_dump_json(), plan.profile_name, repr(plan.duration),
                                   repr(plan.initial_mass), _CODE_FINGERPRINT[0]]).encode()).hexdigest()[:24]
    return cache_dir() / "derived" / f"model_error_{key}.npz"


def _load_derived(plan: RunPlan):
    path = _derived_path(plan)
    try:
        with np.load(path, allow_pickle=False) as z:
            noise, bias = float(z["model_noise"]), np.array(z["discretisation_bias"], dtype=float)
    except (OSError, ValueError, KeyError, EOFError):
        return None
    if not np.isfinite(noise) or bias.ndim != 2 or bias.shape[1] != plan.t_grid.size or not np.all(np.isfinite(bias)):
        return None
    return noise, bias


def _save_derived(plan: RunPlan, noise: float, bias: np.ndarray) -> None:
    from postcapture.io import write_atomic

    def write(tmp):
        with open(tmp, "wb") as f:
            np.savez(f, model_noise=np.array(noise), discretisation_bias=bias)

    try:
        write_atomic(_derived_path(plan), write)
    except OSError as exc:  # a read-only cache costs a derivation per run, nothing more
        import logging

        logging.getLogger(__name__).warning("derived model error not cached (%s)", exc)


def discretisation_bias(plan: RunPlan) -> np.ndarray:
    """What the filters' discretisation does to their parameter estimates: ``(n_p, n_t)`` on the plan's grid.

    The joint filter (:func:`build_augmented`, with the plan's model noise) reads exact sensors of the
    declared truth, ``truth_panel_segments`` integrated to its accuracy, at the nominal parameters, and starts
    from those parameters: whatever its estimates then move by is the model error's doing, not the noise's
    nor the prior's. A model error no parameter describes biases the parameters that can absorb it (the
    5-segment wing's missing flexibility shows up in the inertia about y); the schemes carry this bias as
    a consider term, ``b b^T`` added to the covariance they report (:func:`with_discretisation_bias`), so
    that their sigma covers it. Zero when the truth declares the filters' own panels.
    """
    from postcapture.dynamics.build import build_system
    from postcapture.dynamics.process_model import NativeProcessModel
    from postcapture.dynamics.simulate import simulate
    from postcapture.estimation.schemes import run_joint_scheme
    from postcapture.studies.cases import filter_noise
    from postcapture.studies.sensing import measure_all, noiseless

    sc = plan.scenario
    n_seg = sc.uncertainty.truth_panel_segments
    n_p = len(build_system(sc).parameter_names)
    if n_seg is None or all(p.segments == n_seg for _, p in sc.panels()):
        return np.zeros((n_p, plan.t_grid.size))
    truth = simulate(sc.with_panel_segments(n_seg), duration=plan.duration)
    sensors = measure_all(truth, noiseless(plan.filter_profile), np.random.default_rng(0),
                          accelerometer_position=sc.chaser.accelerometer_position,
                          mean_motion=orbit_mean_motion(sc, "truth"))
    est = sc.estimation
    model = NativeProcessModel.for_filters(sc)
    model.jacobian = "every_step"  # the bound: every step's exact Jacobian
    nominal = model.params
    at_nominal = dataclasses.replace(plan, initial_mass=plan.nominal_mass)
    filt = build_augmented(at_nominal, model, truth["q_BN"][:, 0], name="discretisation")
    run = run_joint_scheme(filt, sensors, plan.t_grid, R=filter_noise(plan.filter_profile, plan.tuning, sc.n_arm),
                           panel_mass=sum(p.mass for p in sc.target.panels), name="discretisation", detection=None)
    return np.nan_to_num(run.params - nominal[:, None])


def with_discretisation_bias(result, bias: np.ndarray | None):
    """A scheme result whose reported covariance carries the discretisation's bias as a consider term.

    ``bias`` (n_p, n_t) from :func:`discretisation_bias`: each instant's parameter 1-sigma becomes
    ``sqrt(sigma^2 + b^2)`` (the total mass's too) and the final covariance ``C + b b^T``.
    """
    if bias is None or result.params is None or not np.any(bias):
        return result
    n = min(bias.shape[1], result.params_sigma.shape[1])
    result.params_sigma[:, :n] = np.sqrt(result.params_sigma[:, :n] ** 2 + bias[:, :n] ** 2)
    result.mass_sigma[:n] = np.sqrt(result.mass_sigma[:n] ** 2 + bias[0, :n] ** 2)
    if result.params_cov is not None:
        b = bias[:, n - 1]
        result.params_cov = result.params_cov + np.outer(b, b)
    return result


def model_noise_vector(model, noise) -> np.ndarray:
    """Model noise as the filter takes it: a full covariance (n, n) as given, else per velocity coordinate (nv,)
    from ``{"chaser": ..., "arm": ..., "panels": ...}`` or a scalar."""
    nv = model.n // 2
    if noise is None:
        raise ValueError("model noise: derive it first (with_model_noise) or set estimation.tuning.<profile>.model_noise")
    if isinstance(noise, np.ndarray) and noise.ndim == 2:
        return noise
    if np.isscalar(noise):
        return np.full(nv, float(noise))
    layout = model.system.layout
    out = np.zeros(nv)
    out[:3] = noise.get("chaser_velocity", noise.get("chaser", 0.0))
    out[3:6] = noise.get("chaser_rate", noise.get("chaser", 0.0))
    out[list(layout.arm_v)] = noise.get("arm", 0.0)
    for panel in layout.panels:
        idx = [i for i in (panel.torsion_v, *panel.bending_v) if i is not None]
        out[idx] = noise.get("panels", 0.0)
    return out


def build_augmented(plan: RunPlan, model, q0_BN, *, name: str,
                    model_noise=None, initial=None) -> AugmentedEKF:
    """An :class:`AugmentedEKF` for a plan: the groups, the prior, the tunings, the initial state.

    ``model_noise`` overrides the plan's (derived or set) model-error process noise; ``initial``, a pair
    ``(x0, d x0 / d p)``, the model's own initial state and sensitivity (an FMU's start values do not
    follow its parameters: its scenario's do).
    """
    estimate, consider = parameter_groups(plan)
    est_map = ParameterMap(model.param_names, model.params, estimate)
    pmap = ParameterMap(model.param_names, model.params, est_map.groups + tuple(g for g in consider
                                                                                   if g not in est_map.groups))
    eta0, P_eta = parameter_prior(plan, pmap)
    x0, S0 = initial if initial is not None else (model.initial_state(), initial_state_sensitivity(model))
    tun = plan.tuning
    prof = plan.filter_profile
    tuning = AugmentedTuning(
        R_star=tun.star_covariance,
        sigma_gyro_bias_walk=prof.gyro.sigma_u,
        sigma_accel_bias_walk=prof.accelerometer.sigma_bias_walk,
        P0_attitude=tun.attitude_P0,
        P0_gyro_bias=tun.gyro_bias_initial_sigma**2,
        P0_accel_bias=tun.accelerometer_bias_initial_sigma**2,
        P0_state=1e-16,
        model_noise=model_noise_vector(model, tun.model_noise if model_noise is None else model_noise),
        P0_gyro_scale=tun.gyro_scale_sigma**2,
        P0_gyro_misalignment=tun.gyro_misalignment_sigma**2,
        mean_motion=orbit_mean_motion(plan.scenario, "filters"),
        gate_probability=tun.gate_probability,
    )
    return AugmentedEKF(model, x0, params=pmap, n_consider=pmap.size - est_map.size, eta0=eta0, P_eta=P_eta, S0=S0,
                        tuning=tuning, q0_BN=q0_BN, name=name)


def bound_with_model_error(plan: RunPlan, model_noise, progress=None):
    """The posterior Cramer-Rao bound of the mass with every declared parameter unknown and the model error.

    For a system with process noise the bound follows the Riccati recursion of the information along the
    true trajectory (Tichavsky, Muravchik and Nehorai, IEEE Trans. Signal Processing 46(5), 1998); with
    additive Gaussian noise it is the covariance of the Kalman filter linearised at the truth. It is
    computed as exactly that: an AugmentedEKF that estimates every declared group (none considered),
    with the model-error process noise ``model_noise``, started at the true values with the declared
    prior, reading noise-free measurements of the filters' own model at the truth's parameters, so that
    its estimate never leaves the truth and its covariance is the bound. Returns the SchemeResult (its
    ``mass_sigma`` is the bound over time).
    """
    from postcapture.dynamics.build import build_system
    from postcapture.dynamics.process_model import NativeProcessModel
    from postcapture.dynamics.simulate import simulate
    from postcapture.estimation.schemes import run_joint_scheme
    from postcapture.studies.cases import filter_noise
    from postcapture.studies.sensing import measure_all, noiseless

    sc = plan.scenario
    est = sc.estimation
    traj = simulate(sc, duration=plan.duration, parameters=plan.truth.parameters, integrator=est.integrator,
                    step=est.model_step, side="filters")  # the filters' own model: its estimate never leaves the truth
    sensors = measure_all(traj, noiseless(plan.filter_profile), np.random.default_rng(0),
                          accelerometer_position=sc.chaser.accelerometer_position,
                          mean_motion=orbit_mean_motion(sc, "filters"))
    model = NativeProcessModel.for_filters(sc)
    nominal = model.params
    estimate, consider = parameter_groups(plan)
    pmap = ParameterMap(model.param_names, nominal, estimate + tuple(g for g in consider if g not in estimate))
    _, P_prior = parameter_prior(plan, pmap, initial_mass=plan.nominal_mass)
    x0_nominal = model.initial_state()
    model.update_params(plan.truth.parameters)
    x0_true = model.initial_state()
    S0 = initial_state_sensitivity(model)
    model.set_params(nominal)
    tun, prof = plan.tuning, plan.filter_profile
    tuning = AugmentedTuning(
        R_star=tun.star_covariance, sigma_gyro_bias_walk=prof.gyro.sigma_u,
        sigma_accel_bias_walk=prof.accelerometer.sigma_bias_walk, P0_attitude=tun.attitude_P0,
        P0_gyro_bias=tun.gyro_bias_initial_sigma**2, P0_accel_bias=tun.accelerometer_bias_initial_sigma**2,
        model_noise=model_noise_vector(model, 0.0 if model_noise is None else model_noise),
        P0_gyro_scale=tun.gyro_scale_sigma**2, P0_gyro_misalignment=tun.gyro_misalignment_sigma**2,
        gate_probability=None,
    )
    p_true = nominal.copy()
    for name, value in plan.truth.parameters.items():
        p_true[model.param_names.index(name)] = value
    filt = AugmentedEKF(model, x0_nominal, params=pmap, n_consider=0, eta0=pmap.from_model(p_true), P_eta=P_prior,
                        S0=S0, tuning=tuning, q0_BN=traj["q_BN"][:, 0], name="bound")
    filt.x = x0_true  # exactly on the truth (the constructor moves x0 to first order only)
    filt._clone = filt._clone_values(filt.x)
    return run_joint_scheme(filt, sensors, plan.t_grid, R=filter_noise(prof, tun, sc.n_arm),
                            panel_mass=sum(p.mass for p in sc.target.panels), progress=progress, name="bound")


def mass_bounds(plan: RunPlan, progress=None) -> dict:
    """Cramer-Rao bounds of the mass on the plan's truth: ``{"known_model", "parameters", "nuisance"}``.

    ``known_model``: the mass is the only unknown of the plant (besides the biases and the initial
    attitude); ``parameters``: every parameter group the scenario declares uncertain is unknown too, with
    its declared prior (the filters' own coordinates and prior); ``nuisance``: on top of that, the declared
    model error (the process noise the filters use, :func:`bound_with_model_error`; the same as
    ``parameters`` when there is none). All on the truth's model and noise.
    """
    from postcapture.dynamics.process_model import NativeProcessModel
    from postcapture.estimation.crlb import mass_crlb

    sc = plan.truth.scenario
    est = plan.scenario.estimation
    model = NativeProcessModel.for_filters(sc, plan.truth.build(), side="truth")
    x0 = model.initial_state()
    dx0 = initial_state_sensitivity(model)
    prof = plan.truth_profile
    common = dict(R_star=prof.star_tracker.covariance(), sigma_gyro=prof.gyro.sample_sigma,
                  R_accel=np.concatenate([np.full(3, prof.accelerometer.sigma**2),
                                          np.full(plan.scenario.n_arm, prof.joints.sample_sigma**2)]),
                  bias_priors=(plan.tuning.gyro_bias_initial_sigma**2, plan.tuning.accelerometer_bias_initial_sigma**2),
                  calibration_priors=((plan.tuning.gyro_scale_sigma**2, plan.tuning.gyro_misalignment_sigma**2)
                                      if plan.tuning.gyro_scale_sigma > 0 else None))
    dpdm = model.system.dparams_dmass()
    known = mass_crlb(model, x0, dx0, plan.t_grid, directions=dpdm[:, None], mass_gradient=np.ones(1),
                      progress=None if progress is None else (lambda f: progress(0.5 * f)), **common)
    estimate, consider = parameter_groups(plan)
    nominal = NativeProcessModel.for_filters(plan.scenario, build_nominal(plan))
    pmap = ParameterMap(model.param_names, nominal.params, estimate + tuple(g for g in consider if g not in estimate))
    _, P_prior = parameter_prior(plan, pmap, initial_mass=plan.nominal_mass)
    D = pmap.jacobian(pmap.from_model(model.params))
    parameters = mass_crlb(model, x0, dx0, plan.t_grid, directions=D, mass_gradient=D[0],
                           prior_information=np.linalg.inv(P_prior),
                           progress=None if progress is None else (lambda f: progress(0.4 + 0.3 * f)), **common)
    nuisance = parameters
    if plan.tuning.model_noise is not None and np.any(plan.tuning.model_noise):
        run = bound_with_model_error(plan, plan.tuning.model_noise,
                                     progress=None if progress is None else (lambda f: progress(0.7 + 0.3 * f)))
        # the per-sensor breakdown is the batch bound's (parameters only); this one is for all sensors together
        nuisance = MassCRLB(all_sensors=float(run.mass_sigma[-1]), star_tracker=None, gyro=None, accelerometer=None,
                            joints=None, accelerations_only=None, history=run.mass_sigma)
    return {"known_model": known, "parameters": parameters, "nuisance": nuisance}


def build_nominal(plan: RunPlan):
    """The filters' (nominal) plant system of a plan."""
    from postcapture.dynamics.build import build_system

    return build_system(plan.scenario)
