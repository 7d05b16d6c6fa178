"""Truth simulation: integrate the plant over a run and record its outputs.

The whole time loop runs in the compiled core (``csrc/pc_integrator.c``), outputs recorded at every
sample without Python in between. The run also integrates, with the integrator's own quadrature, the
energy and momentum the inputs and dampers put in or take out, so that conservation can be checked on
any run:

    E(t) - E(0) = W_in(t) - W_damp(t),     H_O(t) - H_O(0) = integral of the external moment about O,

with O the origin of N (the angular momentum about the centre of mass follows from H_O = H_c + c x p).
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable

import numpy as np

from postcapture.config.limits import check_resources, estimate_simulation, truth_step_guess
from postcapture.config.schema import Scenario, orbit_mean_motion
from postcapture.dynamics.accuracy import choose_step, newton_for
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.outputs import OutputSpec, fill_outputs, output_specs
from postcapture.dynamics.stability import check_step
from postcapture.dynamics.system import System
from postcapture.dynamics.trajectory import StateLayout, Trajectory

__all__ = ["simulate", "simulate_system", "drift_metrics"]


def drift_metrics(traj: Trajectory) -> dict[str, float]:
    """Relative drift of energy and angular momentum, net of what inputs and dampers exchanged.

    ``energy_drift_rel = max |E(t) - E(0) - W(t)| / E(0)``;
    ``angular_momentum_drift_rel = max |H_O(t) - H_O(0) - int M_O dt| / |H_c(0)|`` with the angular
    momentum about N's origin ``H_O = H_c + c x p`` (c the centre of mass, p the linear momentum).
    """
    E = traj["energy"][0]
    W = traj["work_in"][0]
    Hc = traj["angular_momentum_N"]
    H_O = Hc + np.cross(traj["com_N"], traj["momentum_N"], axis=0)
    Mi = traj["moment_impulse_N"]
    e0 = abs(E[0]) if E[0] != 0 else 1.0
    h0 = float(np.linalg.norm(Hc[:, 0])) or 1.0
    return {
        "energy_drift_rel": float(np.max(np.abs(E - E[0] - W)) / e0),
        "angular_momentum_drift_rel": float(np.max(np.linalg.norm(H_O - H_O[:, :1] - Mi, axis=0)) / h0),
    }


def simulate_system(
    system: System,
    q0: np.ndarray,
    v0: np.ndarray,
    duration: float,
    *,
    step: float,
    sample_period: float,
    integrator: str = "sdirk3",
    t0: float = 0.0,
    progress: Callable[[float], None] | None = None,
    newton: tuple[float, float] | None = None,
    mean_motion: float = 0.0,
) -> Trajectory:
    """Integrate a built system from ``(q0, v0)`` and record its outputs every ``sample_period``.

    Parameters
    ----------
    system : System
    q0, v0 : ndarray
        Initial configuration (nq,) and velocity (nv,).
    duration, step, sample_period : float
        Seconds; ``sample_period`` must be a whole multiple of ``step``.
    integrator : {"sdirk3", "sdirk2", "rk4"}
    progress : callable, optional
        Called with the fraction done (0..1) after each sample.
    newton : (float, float), optional
        Newton acceptance of the implicit stages (relative, absolute); default the core's (1e-10, 1e-15).
    mean_motion : float
        Of a circular orbit whose gravity gradient acts on every body (rad/s; 0: free space;
        :meth:`postcapture.dynamics.core.CompiledPlant.set_orbit`).

    Returns
    -------
    Trajectory

    Raises
    ------
    StepTooLargeError
        For an explicit integrator whose step is beyond the plant's stability limit (the message gives it).
    """
    ratio = sample_period / step
    per = int(round(ratio))
    if per < 1 or abs(ratio - per) > 1e-9:
        raise ValueError(f"sample_period: expected a whole multiple of step = {step}, found {sample_period}")
    check_resources(estimate_simulation(nv=system.nv, duration=duration, step=step, sample_period=sample_period,
                                        integrator=integrator))
    n = int(round(duration / sample_period)) + 1
    plant = CompiledPlant(system, integrator)
    if mean_motion:
        plant.set_orbit(mean_motion)
    check_step(plant, q0, v0, step)
    if newton is not None:
        plant.set_newton(*newton)
    hist = {"q": np.zeros((n, system.nq)), "v": np.zeros((n, system.nv)), "ddq": np.zeros((n, system.nv)),
            "panels": np.zeros((n, plant.npanels, 4)), "mech": np.zeros((n, 11 + plant.nz)),
            "balance": np.zeros((n, 7)), "u": np.zeros((n, system.n_u))}
    q, v = np.array(q0, dtype=float), np.array(v0, dtype=float)
    # chunks of samples, so that progress is reported and the caller regains control between them
    chunk = max(1, (n - 1) // 50) if progress is not None else n
    wall0 = _time.perf_counter()
    k0, bal0 = 0, np.zeros(7)
    while True:
        k1 = min(n - 1, k0 + chunk) if n > 1 else 0
        out = plant.simulate(q, v, t0, step, per, k1 - k0 + 1, balance0=bal0, sample_period=sample_period,
                             first_sample=k0)
        first = 0 if k0 == 0 else 1  # a chunk's first sample repeats the previous chunk's last
        for key in hist:
            hist[key][k0 + first : k1 + 1] = out[key][first:]
        q, v, bal0 = out["q_end"], out["v_end"], out["balance"][-1]
        if progress is not None:
            progress((k1 + 1) / n)
        if k1 >= n - 1:
            break
        k0 = k1
    wall = _time.perf_counter() - wall0
    specs = output_specs(system)
    outputs = {s.name: np.zeros((len(s.components), n)) for s in specs}
    fill_outputs(system, outputs, slice(0, n), hist["q"].T, hist["v"].T, hist["ddq"].T, hist["panels"],
                 hist["mech"].T, hist["u"].T)
    bal = hist["balance"].T
    outputs["work_in"] = bal[:1]
    outputs["moment_impulse_N"] = bal[1:4]
    outputs["impulse_N"] = bal[4:7]
    specs = specs + [
        OutputSpec("work_in", ("value",), "J", "work done by the inputs minus energy dissipated by the dampers"),
        OutputSpec("moment_impulse_N", ("x", "y", "z"), "N m s", "time integral of the external moment about the origin of N"),
        OutputSpec("impulse_N", ("x", "y", "z"), "N s", "time integral of the external force"),
    ]
    attrs = {
        "integrator": integrator,
        "step_s": step,
        "sample_period_s": sample_period,
        "nq": system.nq,
        "nv": system.nv,
        "wall_s": wall,
        "newton_iterations": plant.stats()["newton_iterations"],
    }
    return Trajectory(np.array([t0 + k * sample_period for k in range(n)]), hist["q"].T.copy(), hist["v"].T.copy(),
                      hist["ddq"].T.copy(), outputs, specs, attrs, layout=StateLayout.from_system(system))


def simulate(
    scenario: Scenario,
    *,
    variant: str = "flexible",
    duration: float | None = None,
    panel_segments: int | None = None,
    damping: bool = True,
    excitation: bool = True,
    integrator: str | None = None,
    step: float | None = None,
    sample_period: float | None = None,
    parameters: dict | None = None,
    progress: Callable[[float], None] | None = None,
    side: str = "truth",
) -> Trajectory:
    """Simulate a scenario's truth from its initial state.

    Settings default to the scenario's ``[simulation]`` section; ``parameters`` overrides named model
    parameters (:mod:`postcapture.dynamics.parameters`, e.g. a truth drawn from the priors). Without an
    explicit ``step`` (here or in ``[simulation]``), the scenario's declared accuracy sets the truth's step
    (:func:`postcapture.dynamics.accuracy.choose_step`). ``side = "filters"`` simulates what the filters'
    model is instead (the orbit's gravity gradient only if ``[orbit] filters = "model"``).

    Examples
    --------
    >>> from postcapture.config import load_scenario
    >>> traj = simulate(load_scenario("envisat"), duration=1.0)
    >>> traj["q_BN"].shape
    (4, 11)
    """
    sim = scenario.simulation
    system = build_system(scenario, variant, panel_segments=panel_segments, damping=damping,
                          excitation=excitation).with_updates(parameters or {})
    duration = sim.duration if duration is None else duration
    sample_period = sim.sample_period if sample_period is None else sample_period
    integrator = sim.integrator if integrator is None else integrator
    step = sim.step if step is None else step
    chosen = step is None  # the truth's step from its declared accuracy (the pilot below)
    # refused before the initial state is solved (a huge model's relaxation alone can take long)
    check_resources(estimate_simulation(nv=system.nv, duration=duration,
                                        step=truth_step_guess(sample_period) if chosen else step,
                                        sample_period=sample_period, integrator=integrator))
    q0, v0 = initial_state(system)
    newton = None
    if chosen:
        newton = newton_for(sim.tolerance)
        step = choose_step(system, q0, v0, duration=duration, sample_period=sample_period, tolerance=sim.tolerance,
                           joint_tolerance=sim.joint_tolerance, rate_tolerance=sim.rate_tolerance, method=integrator)
    traj = simulate_system(
        system,
        q0,
        v0,
        duration,
        step=step,
        sample_period=sample_period,
        integrator=integrator,
        progress=progress,
        newton=newton,
        mean_motion=orbit_mean_motion(scenario, side),
    )
    traj.attrs["tolerance_rad"] = sim.tolerance if chosen else 0.0
    traj.attrs.update(
        scenario=scenario.name,
        variant=variant,
        panel_segments=",".join(str(p.segments) for _, p in system.scenario.panels()),
        damping=str(damping),
        excitation=str(excitation),
    )
    return traj
