"""The truth apart from the filters: what the simulated world is, when it is not the filters' nominal model.

A :class:`TruthModel` is a scenario to build the plant from (its panel discretisation included),
overrides of the named parameter vector (:mod:`postcapture.dynamics.parameters`) and, optionally, the
true turn-on sensor biases. Three ways to get one:

- :func:`nominal_truth`: the nominal scenario itself (the filters' parameters, on the truth's own integrator and step);
- :func:`truth_from_scenario`: another scenario file of the same structure (same arm, same panels);
- :func:`draw_truth`: a draw from the nominal scenario's ``[uncertainty]`` priors, reproducible from
  its seed. The target's mass, centre of mass and inertia are drawn for the whole target (panels
  included, as published); its panels keep their own geometry, so the rigid hub takes up the change.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.transform import Rotation

from postcapture.config.flexibility import refine_stiffness
from postcapture.config.schema import Scenario
from postcapture.core.errors import Problem, ScenarioError
from postcapture.dynamics.bodies import MassProperties, hub_properties, panel_properties, parallel_axis
from postcapture.dynamics.build import build_system
from postcapture.dynamics.parameters import INERTIAL_NAMES, dynamic_parameters, mass_properties
from postcapture.dynamics.system import System

__all__ = ["TruthModel", "nominal_truth", "truth_from_scenario", "draw_parameters", "draw_truth",
           "truth_vector_names", "check_priors", "target_properties"]

_TRUTH_STREAM = 0x7472757468  # keeps truth draws independent of the sensor-noise streams of the same seed
_MAX_REDRAWS = 1000


@dataclass(frozen=True)
class TruthModel:
    """The simulated world.

    Attributes
    ----------
    scenario : Scenario
        What the truth plant is built from (its own panel segments).
    parameters : dict of str to float
        Values of named parameters that differ from what ``scenario`` gives.
    gyro_bias_B, accel_bias_B : ndarray, shape (3,), optional
        True turn-on biases (rad/s, m/s^2); None keeps the sensor profile's.
    gyro_scale_factor : ndarray, shape (3,), optional
        The gyro's true scale-factor errors (relative); None keeps the profile's.
    gyro_misalignment : ndarray, shape (3, 3), optional
        Its true misalignment (rad, zero diagonal); None keeps the profile's.
    source : str
        ``"nominal"``, ``"scenario <path>"`` or ``"draw <seed>"``.
    """

    scenario: Scenario
    parameters: dict = field(default_factory=dict)
    gyro_bias_B: np.ndarray | None = None
    accel_bias_B: np.ndarray | None = None
    source: str = "nominal"
    gyro_scale_factor: np.ndarray | None = None
    gyro_misalignment: np.ndarray | None = None

    def build(self, variant: str = "flexible", **kwargs) -> System:
        """The truth plant (``build_system`` of the scenario, then the parameter overrides)."""
        return build_system(self.scenario, variant, **kwargs).with_updates(self.parameters)

    def describe(self, nominal: Scenario) -> dict:
        """The truth's physical parameters, for tables and result files (see :func:`truth_vector_names`)."""
        names = truth_vector_names(nominal)
        values = self.vector(nominal)
        out = {"source": self.source, "panel_segments": [p.segments for _, p in self.scenario.panels()]}
        out.update({n: float(v) for n, v in zip(names, values)})
        return out

    def vector(self, nominal: Scenario) -> np.ndarray:
        """The truth as numbers named by :func:`truth_vector_names` (target in the grasp frame G, scales
        relative to the nominal scenario, biases; NaN where not applicable)."""
        sc = self.scenario
        out: list[float] = []
        if sc.target is not None:
            in_G = target_properties(sc, self.build().parameters()[:10])
            I = in_G.inertia
            out += [in_G.mass, *in_G.com, I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]
        for (_, panel), (_, ref) in zip(sc.panels(), nominal.panels()):
            k_ref = refine_stiffness(ref.bending_stiffness, ref.length, panel.segments)
            scales = (float(np.mean(np.asarray(panel.bending_stiffness) / k_ref)),
                      panel.torsion_stiffness / ref.torsion_stiffness,
                      (panel.damping_beta / ref.damping_beta) if ref.damping_beta > 0 else float("nan"))
            out += [s * self.parameters.get(f"{panel.name}.{kind}_scale", 1.0)
                    for s, kind in zip(scales, ("bending", "torsion", "damping"))]
        if sc.arm is not None:
            ratio_k = np.mean([j.stiffness / r.stiffness for j, r in zip(sc.arm.joints, nominal.arm.joints)])
            d_ref = [r.damping for r in nominal.arm.joints]
            ratio_d = (np.mean([j.damping / r for j, r in zip(sc.arm.joints, d_ref) if r > 0])
                       if any(r > 0 for r in d_ref) else float("nan"))
            out += [ratio_k * self.parameters.get("arm.stiffness_scale", 1.0),
                    ratio_d * self.parameters.get("arm.damping_scale", 1.0)]
        nan3 = [float("nan")] * 3
        out += list(self.gyro_bias_B) if self.gyro_bias_B is not None else nan3
        out += list(self.accel_bias_B) if self.accel_bias_B is not None else nan3
        return np.array(out, dtype=float)


def truth_vector_names(nominal: Scenario) -> tuple[str, ...]:
    """Names of :meth:`TruthModel.vector` (units: kg, m, kg m^2, factors, rad/s, m/s^2)."""
    names: list[str] = []
    if nominal.target is not None:
        names += ["target_mass", "target_com_x", "target_com_y", "target_com_z", "target_I_xx", "target_I_yy",
                  "target_I_zz", "target_I_xy", "target_I_xz", "target_I_yz"]
    for _, panel in nominal.panels():
        names += [f"{panel.name}.bending_scale", f"{panel.name}.torsion_scale", f"{panel.name}.damping_scale"]
    if nominal.arm is not None:
        names += ["arm.stiffness_scale", "arm.damping_scale"]
    names += ["gyro_bias_x", "gyro_bias_y", "gyro_bias_z", "accel_bias_x", "accel_bias_y", "accel_bias_z"]
    return tuple(names)


def target_properties(scenario: Scenario, pi_hub) -> MassProperties:
    """The whole target (hub of inertial parameters ``pi_hub`` in T, plus its undeformed panels) in the grasp
    frame G: mass (kg), centre of mass (m) and inertia about it (kg m^2), G axes."""
    whole = _whole_target(scenario, mass_properties(pi_hub))
    pose = scenario.target.grasp_to_com
    return whole.transformed(pose.rotation(), pose.translation())


def _panel_mounts(scenario: Scenario, shift=np.zeros(3)):
    return [(p.mount.rotation(), p.mount.translation() - shift, panel_properties(p)) for p in scenario.target.panels]


def _whole_target(scenario: Scenario, hub: MassProperties) -> MassProperties:
    """Hub plus undeformed panels, in T (mass, CoM, inertia about the CoM)."""
    parts = [hub] + [props.transformed(R, p) for R, p, props in _panel_mounts(scenario)]
    m = sum(b.mass for b in parts)
    c = sum(b.mass * b.com for b in parts) / m
    I_O = sum(b.about_origin() for b in parts)
    return MassProperties(m, c, I_O - parallel_axis(m, c))


def nominal_truth(scenario: Scenario) -> TruthModel:
    """The truth is the nominal model."""
    return TruthModel(scenario)


def truth_from_scenario(nominal: Scenario, other: Scenario, source: str = "") -> TruthModel:
    """A truth built from another scenario of the same structure.

    Raises
    ------
    ScenarioError
        If the two differ in structure: arm joint count, target presence, panel names or hosts.
    """
    problems = []
    if nominal.n_arm != other.n_arm:
        problems.append(Problem("truth scenario: arm.joints", f"{nominal.n_arm} joints like the nominal scenario",
                                f"{other.n_arm}"))
    if (nominal.target is None) != (other.target is None):
        problems.append(Problem("truth scenario: target", "a target exactly when the nominal scenario has one",
                                "none" if other.target is None else "a target"))
    ours = [(host, p.name) for host, p in nominal.panels()]
    theirs = [(host, p.name) for host, p in other.panels()]
    if ours != theirs:
        problems.append(Problem("truth scenario: panels", f"the nominal scenario's panels {ours}", f"{theirs}"))
    if problems:
        raise ScenarioError(problems, source or None)
    return TruthModel(other, source=f"scenario {source}".strip())


def _draw_target(scenario: Scenario, rng: np.random.Generator) -> np.ndarray:
    """Ten inertial parameters of the hub (nominal T frame) for a whole target drawn from the priors."""
    unc, tg = scenario.uncertainty, scenario.target
    I_nom = np.asarray(tg.inertia, dtype=float)
    lam, V = np.linalg.eigh(I_nom)
    for _ in range(_MAX_REDRAWS):
        m = tg.mass + (float(unc.target_mass.sample(rng)) if unc.target_mass else 0.0)
        dc = unc.target_com.sample(rng, 3) if unc.target_com else np.zeros(3)
        f = unc.target_inertia_moments.sample(rng, 3, factor=True) if unc.target_inertia_moments else np.ones(3)
        rot = unc.target_inertia_axes.sample(rng, 3) if unc.target_inertia_axes else np.zeros(3)
        Rd = Rotation.from_rotvec(rot).as_matrix()
        I = Rd @ V @ np.diag(lam * f) @ V.T @ Rd.T
        a, b, c = np.sort(np.linalg.eigvalsh(I))
        if a <= 0 or a + b < c:  # a body that cannot exist: draw again (the prior is cut to physical bodies)
            continue
        if not tg.properties_include_panels:
            return dynamic_parameters(MassProperties(m, dc, I))
        try:  # the published numbers include the panels: the hub is what is left, about the drawn CoM
            hub = hub_properties(m, I, _panel_mounts(scenario, dc), "target")
        except ScenarioError:
            continue
        return dynamic_parameters(MassProperties(hub.mass, hub.com + dc, hub.inertia))
    raise ScenarioError([Problem("uncertainty.target_inertia_moments",
                                 "priors under which a physical target (positive definite, triangle inequality, a hub "
                                 "heavier than nothing once the panels are out) can be drawn",
                                 f"no physical draw in {_MAX_REDRAWS} attempts")])


def draw_parameters(scenario: Scenario, rng: np.random.Generator) -> dict[str, float]:
    """Model parameters (by name) drawn from the scenario's ``[uncertainty]`` priors; the declared ones only."""
    unc = scenario.uncertainty
    params: dict[str, float] = {}
    if scenario.target is not None:
        params.update({f"target.{n}": float(v) for n, v in zip(INERTIAL_NAMES, _draw_target(scenario, rng))})
    for _, panel in scenario.panels():
        for kind, prior in (("bending", unc.panel_bending), ("torsion", unc.panel_torsion),
                            ("damping", unc.panel_damping)):
            if prior is not None:
                params[f"{panel.name}.{kind}_scale"] = float(prior.sample(rng, factor=True))
    if scenario.arm is not None:
        for kind, prior in (("stiffness", unc.arm_stiffness), ("damping", unc.arm_damping)):
            if prior is not None:
                params[f"arm.{kind}_scale"] = float(prior.sample(rng, factor=True))
    return params


def draw_truth(scenario: Scenario, seed) -> TruthModel:
    """A truth drawn from the scenario's ``[uncertainty]`` priors, reproducible from ``seed`` (an int >= 0, or a
    sequence of them, e.g. ``(scenario seed, run index)``)."""
    unc = scenario.uncertainty
    seeds = [int(s) for s in np.atleast_1d(seed)]
    rng = np.random.default_rng([*seeds, _TRUTH_STREAM])
    truth_sc = scenario if unc.truth_panel_segments is None else scenario.with_panel_segments(unc.truth_panel_segments)
    params = draw_parameters(scenario, rng)
    gyro = unc.gyro_bias.sample(rng, 3) if unc.gyro_bias else None
    accel = unc.accelerometer_bias.sample(rng, 3) if unc.accelerometer_bias else None
    scale = unc.gyro_scale_factor.sample(rng, 3) if unc.gyro_scale_factor else None
    mis = None
    if unc.gyro_misalignment:
        mis = np.zeros((3, 3))
        mis[~np.eye(3, dtype=bool)] = unc.gyro_misalignment.sample(rng, 6)
    return TruthModel(truth_sc, params, gyro, accel, source="draw " + ",".join(str(x) for x in seeds),
                      gyro_scale_factor=scale, gyro_misalignment=mis)


def check_priors(scenario: Scenario, draws: int = 200) -> None:
    """Refuse priors under which most target draws are not physical bodies (before any long work).

    Raises
    ------
    ScenarioError
        Naming the prior, when fewer than half of ``draws`` trial draws give a physical target.
    """
    unc = scenario.uncertainty
    if scenario.target is None or (unc.target_inertia_moments is None and unc.target_inertia_axes is None):
        return
    rng = np.random.default_rng(0)
    tg = scenario.target
    lam, V = np.linalg.eigh(np.asarray(tg.inertia, dtype=float))
    ok = 0
    for _ in range(draws):
        f = unc.target_inertia_moments.sample(rng, 3, factor=True) if unc.target_inertia_moments else np.ones(3)
        rot = unc.target_inertia_axes.sample(rng, 3) if unc.target_inertia_axes else np.zeros(3)
        Rd = Rotation.from_rotvec(rot).as_matrix()
        a, b, c = np.sort(np.linalg.eigvalsh(Rd @ V @ np.diag(lam * f) @ V.T @ Rd.T))
        ok += a > 0 and a + b >= c
    if ok < draws / 2:
        raise ScenarioError([Problem("uncertainty.target_inertia_moments",
                                     "a prior under which most drawn inertias are physical (triangle inequality)",
                                     f"{ok} of {draws} trial draws physical: narrow the prior or truncate it")])
