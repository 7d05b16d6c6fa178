"""``export_estimator_fmu``: an estimation scheme as an FMI 2.0 or 3.0 co-simulation FMU (a recommended one, or
the reference's dual scheme).

The reference implemented its filters inside an FMU, the predictor before ``fmiDoStep`` and the corrector
after. Here one ``fmi2DoStep`` is one filter cycle (the filter period): the predictor runs inside the FMU
with the engine's own plant and exact Jacobians, then the corrector reads the inputs set for that step.
The FMU compiles the engine's sources (``dynamics/csrc``: the plant and the filters, the same as the native
filters run) with ``fmi/csrc/pc_estimator.c`` (the scheme's cycle), ``pc_est_fmu.c`` (the FMU instance both
FMI versions share) and the version's interface (``pc_est_fmi2.c`` or ``pc_est_fmi3.c``; FMI 3.0 adds the
independent variable ``time`` after the others, :mod:`postcapture.studies.estimator_fmu3`).

What it embeds is what the native main job builds for the case (``studies.main_job``): the plan of the
scenario and profile with its derived model noise and discretisation bias, the augmented EKF's prior
(:class:`~postcapture.estimation.augmented.AugmentedSetup`) and, for ``dual``, the MEKF's tuning.

Variables (value references in this order):

- inputs (discrete): ``star_q_w/x/y/z`` and ``star_valid``: the star tracker at the cycle's end;
  ``gyro_x/y/z``, ``gyro_valid``: the gyro's mean rate over the cycle (rad/s); ``accel_x/y/z``,
  ``accel_valid``: the accelerometer's mean specific force over the cycle (m/s^2); ``encoder_1..n``,
  ``encoders_valid``: the arm's joint angles at the cycle's end (rad); ``u_1..u_nu``: the commanded force
  (N, 3), torque (N m, 3) and joint torques (N m), added to the scenario's manoeuvre over the cycle. A flag
  below 0.5 makes that measurement missing; a non-finite component is missing and counted.
- parameters: ``q0_BN_w/x/y/z`` (fixed: the initial attitude estimate); tunable: ``R_star[i,j]`` (rad^2),
  ``sigma_gyro`` (rad/s), ``sigma_accel`` (m/s^2), ``sigma_encoder`` (rad), ``model_noise[i]`` ((rad/s)^2 or
  (m/s)^2 per cycle on each plant velocity), ``sigma_gyro_bias_walk``, ``sigma_accel_bias_walk``,
  ``mekf_sigma_v``, ``mekf_sigma_u`` (dual) and ``star_norm_tolerance`` (a star-tracker quaternion whose norm
  is further from 1 is refused as an outlier).
- outputs: ``q_BN_w/x/y/z``, ``omega_BN_B_x/y/z`` (rad/s), ``attitude_sigma_x/y/z`` (rad), ``gyro_bias_x/y/z``
  (rad/s), ``target_mass`` and ``target_mass_sigma`` (kg), the plant's parameter vector ``p.<name>`` with its
  1-sigma ``p_sigma.<name>`` (the target hub's mass, first moment and inertia in T, and the factors), the NIS
  of the accepted updates ``nis_gyro``, ``nis_star``, ``nis_accel``, ``nis_encoders`` (-1 when none: every
  output stays finite), ``n_missing``, ``n_outliers``, ``recoveries`` and ``diverged`` (1 once a filter diverged).

The reference's dual scheme (``ekf_flexible``, ``mekf_flexible``: :mod:`postcapture.estimation.dual`) runs
``fmi/csrc/pc_est_refdual.c`` over the same inputs (the EKF reads no gyro; the MEKF holds the last valid one),
with what :func:`~postcapture.studies.main_job.run_case` builds for the case (its plant copy's initial state and
mass sensitivity, the filters' tuning). Its parameters: ``q0_BN_w/x/y/z``, ``R_star[i,j]``, ``ekf_Q[i,j]``
(EKF: rad^2 per cycle) or ``mekf_sigma_v``, ``mekf_sigma_u`` (MEKF), ``mass_R[i]`` (the mass filter's
variances: accelerometer (m/s^2)^2 then encoders rad^2), ``mass_q_start``, ``mass_q_end`` (its scheduled process
noise), ``mass_q_accel_bias`` (realistic profile), ``mass_schedule_end`` (fixed, s: where the schedule ends,
the run's end) and ``star_norm_tolerance``. Its outputs: ``q_BN_*``, ``omega_BN_B_*`` (the plant copy's),
``attitude_sigma_*``, ``gyro_bias_*`` (MEKF), ``target_mass``, ``target_mass_sigma``, ``accel_bias_*`` (the
mass filter's, realistic profile), ``nis_star``, ``nis_accelerations`` (the mass filter's measurement: the
accelerometer and the encoders together), ``n_missing``, ``n_outliers``, ``recoveries``, ``diverged``. The
reference's mass filter estimates the mass alone, at the nominal centre of mass and inertia about it: the FMU
outputs no centre of mass or inertia.
"""

from __future__ import annotations

import hashlib
import shutil
import uuid
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from postcapture.config.schema import Scenario
from postcapture.fmi._extras import import_fmpy
from postcapture.fmi.export.c_header import _array, _c_string, _num
from postcapture.fmi.export.interface import UNITS
from postcapture.io import check_output_file, scratch_folder

__all__ = ["ESTIMATOR_CASES", "REFERENCE_DUAL_CASES", "EstimatorVariable", "EstimatorExport", "export_estimator_fmu",
           "estimator_variables", "reference_dual_variables"]

ESTIMATOR_CASES = ("joint", "dual", "ekf_flexible", "mekf_flexible")
REFERENCE_DUAL_CASES = ("ekf_flexible", "mekf_flexible")
_RUNTIME = ("pc_estimator.h", "pc_est_inputs.c", "pc_est_fmu.c", "pc_est_fmu.h")
_WRAPPERS = {2: "pc_est_fmi2.c", 3: "pc_est_fmi3.c"}  # the FMI version's interface (fmi/csrc)
_CYCLE = {"joint": "pc_estimator.c", "dual": "pc_estimator.c", "ekf_flexible": "pc_est_refdual.c",
          "mekf_flexible": "pc_est_refdual.c"}  # the scheme's cycle: one per FMU
INPUT, PARAMETER, OUTPUT = 0, 1, 2


@dataclass(frozen=True)
class EstimatorVariable:
    """One real variable of the estimator FMU (its value reference is its index)."""

    name: str
    causality: int  # INPUT, PARAMETER, OUTPUT
    start: float = 0.0
    description: str = ""
    unit: str = ""
    tunable: bool = False
    positive: bool = False


@dataclass
class _Layout:
    variables: list = field(default_factory=list)
    blocks: dict = field(default_factory=dict)

    def add(self, block: str, names, causality: int, starts, *, description: str = "", unit: str = "",
            tunable: bool = False, positive: bool = False) -> None:
        self.blocks[block] = len(self.variables)
        for name, start in zip(names, starts):
            self.variables.append(EstimatorVariable(name, causality, float(start), description, unit, tunable, positive))


@dataclass(frozen=True)
class EstimatorExport:
    """What :func:`export_estimator_fmu` built: the FMU, its case and profile, GUID, filter period and
    the variables (value reference = index)."""

    path: Path
    case: str
    profile: str
    guid: str
    period: float
    variables: tuple
    fmi_version: str = "2.0"


def estimator_variables(n_arm: int, n_u: int, param_names, *, dual: bool, q0, R_star, sigmas: dict,
                        model_noise, mekf: tuple[float, float]) -> _Layout:
    """The variable table of an estimator FMU (see the module docstring)."""
    L = _Layout()
    _inputs(L, n_arm, n_u)
    L.add("Q0", [f"q0_BN_{a}" for a in "wxyz"], PARAMETER, q0, description="initial attitude estimate")
    L.add("R_STAR", [f"R_star[{i + 1},{j + 1}]" for i in range(3) for j in range(3)], PARAMETER,
          np.ravel(R_star), unit="rad2", tunable=True)
    L.add("SIGMA_GYRO", ["sigma_gyro"], PARAMETER, [sigmas["gyro"]], unit="rad/s", tunable=True, positive=True)
    L.add("SIGMA_ACCEL", ["sigma_accel"], PARAMETER, [sigmas["accelerometer"]], unit="m/s2", tunable=True,
          positive=True)
    L.add("SIGMA_ENC", ["sigma_encoder"], PARAMETER, [sigmas["encoders"]], unit="rad", tunable=True, positive=True)
    L.add("MODEL_NOISE", [f"model_noise[{i + 1}]" for i in range(len(model_noise))], PARAMETER, model_noise,
          description="process noise per cycle on each plant velocity", tunable=True, positive=True)
    L.add("SIGMA_GYRO_WALK", ["sigma_gyro_bias_walk"], PARAMETER, [sigmas["gyro_walk"]], tunable=True, positive=True)
    L.add("SIGMA_ACCEL_WALK", ["sigma_accel_bias_walk"], PARAMETER, [sigmas["accel_walk"]], tunable=True,
          positive=True)
    L.add("MEKF_SIGMA_V", ["mekf_sigma_v"], PARAMETER, [mekf[0]], tunable=True, positive=True)
    L.add("MEKF_SIGMA_U", ["mekf_sigma_u"], PARAMETER, [mekf[1]], tunable=True, positive=True)
    L.add("STAR_NORM_TOL", ["star_norm_tolerance"], PARAMETER, [1e-3], tunable=True, positive=True)
    L.add("Q", [f"q_BN_{a}" for a in "wxyz"], OUTPUT, [1, 0, 0, 0], description="attitude estimate")
    L.add("OMEGA", [f"omega_BN_B_{a}" for a in "xyz"], OUTPUT, [0] * 3, unit="rad/s")
    L.add("ATT_SIGMA", [f"attitude_sigma_{a}" for a in "xyz"], OUTPUT, [0] * 3, unit="rad")
    L.add("GYRO_BIAS", [f"gyro_bias_{a}" for a in "xyz"], OUTPUT, [0] * 3, unit="rad/s")
    L.add("MASS", ["target_mass"], OUTPUT, [0], unit="kg")
    L.add("MASS_SIGMA", ["target_mass_sigma"], OUTPUT, [0], unit="kg")
    L.add("P", [f"p.{n}" for n in param_names], OUTPUT, [0] * len(param_names))
    L.add("P_SIGMA", [f"p_sigma.{n}" for n in param_names], OUTPUT, [0] * len(param_names))
    L.add("NIS", ["nis_gyro", "nis_star", "nis_accel", "nis_encoders"], OUTPUT, [0] * 4)
    L.add("N_MISSING", ["n_missing"], OUTPUT, [0])
    L.add("N_OUTLIERS", ["n_outliers"], OUTPUT, [0])
    L.add("RECOVERIES", ["recoveries"], OUTPUT, [0])
    L.add("DIVERGED", ["diverged"], OUTPUT, [0])
    return L


def reference_dual_variables(n_arm: int, n_u: int, *, ekf: bool, q0, R_star, ekf_Q, mekf: tuple[float, float],
                             mass_R, mass_q: tuple[float, float], mass_q_bias: float | None,
                             schedule_end: float) -> _Layout:
    """The variable table of a reference-dual estimator FMU (see the module docstring): the joint and dual FMUs'
    inputs, the reference filters' tuning, and what those filters estimate."""
    L = _Layout()
    _inputs(L, n_arm, n_u)
    L.add("Q0", [f"q0_BN_{a}" for a in "wxyz"], PARAMETER, q0, description="initial attitude estimate")
    L.add("R_STAR", [f"R_star[{i + 1},{j + 1}]" for i in range(3) for j in range(3)], PARAMETER,
          np.ravel(R_star), unit="rad2", tunable=True)
    if ekf:
        L.add("EKF_Q", [f"ekf_Q[{i + 1},{j + 1}]" for i in range(3) for j in range(3)], PARAMETER, np.ravel(ekf_Q),
              description="attitude EKF process noise per cycle", unit="rad2", tunable=True)
    else:
        L.add("MEKF_SIGMA_V", ["mekf_sigma_v"], PARAMETER, [mekf[0]], tunable=True, positive=True)
        L.add("MEKF_SIGMA_U", ["mekf_sigma_u"], PARAMETER, [mekf[1]], tunable=True, positive=True)
    L.add("MASS_R", [f"mass_R[{i + 1}]" for i in range(len(mass_R))], PARAMETER, mass_R,
          description="mass filter measurement variance (accelerometer, then encoders)", tunable=True, positive=True)
    L.add("MASS_Q_START", ["mass_q_start"], PARAMETER, [mass_q[0]], description="mass filter process noise at start",
          tunable=True, positive=True)
    L.add("MASS_Q_END", ["mass_q_end"], PARAMETER, [mass_q[1]], description="mass filter process noise at the end",
          tunable=True, positive=True)
    if mass_q_bias is not None:
        L.add("MASS_Q_BIAS", ["mass_q_accel_bias"], PARAMETER, [mass_q_bias], unit="m2/s4", tunable=True,
              positive=True)
    L.add("MASS_T_END", ["mass_schedule_end"], PARAMETER, [schedule_end], unit="s",
          description="end of the mass filter's process-noise schedule")
    L.add("STAR_NORM_TOL", ["star_norm_tolerance"], PARAMETER, [1e-3], tunable=True, positive=True)
    L.add("Q", [f"q_BN_{a}" for a in "wxyz"], OUTPUT, [1, 0, 0, 0], description="attitude estimate")
    L.add("OMEGA", [f"omega_BN_B_{a}" for a in "xyz"], OUTPUT, [0] * 3, unit="rad/s")
    L.add("ATT_SIGMA", [f"attitude_sigma_{a}" for a in "xyz"], OUTPUT, [0] * 3, unit="rad")
    if not ekf:
        L.add("GYRO_BIAS", [f"gyro_bias_{a}" for a in "xyz"], OUTPUT, [0] * 3, unit="rad/s")
    L.add("MASS", ["target_mass"], OUTPUT, [0], unit="kg")
    L.add("MASS_SIGMA", ["target_mass_sigma"], OUTPUT, [0], unit="kg")
    if mass_q_bias is not None:
        L.add("ACCEL_BIAS", [f"accel_bias_{a}" for a in "xyz"], OUTPUT, [0] * 3, unit="m/s2")
    L.add("NIS", ["nis_star", "nis_accelerations"], OUTPUT, [0] * 2)
    L.add("N_MISSING", ["n_missing"], OUTPUT, [0])
    L.add("N_OUTLIERS", ["n_outliers"], OUTPUT, [0])
    L.add("RECOVERIES", ["recoveries"], OUTPUT, [0])
    L.add("DIVERGED", ["diverged"], OUTPUT, [0])
    return L


def _inputs(L: _Layout, n_arm: int, n_u: int) -> None:
    """The inputs every estimator FMU reads (their value references first)."""
    L.add("STAR", [f"star_q_{a}" for a in "wxyz"], INPUT, [1, 0, 0, 0], description="star tracker q_BN")
    L.add("STAR_VALID", ["star_valid"], INPUT, [0])
    L.add("GYRO", [f"gyro_{a}" for a in "xyz"], INPUT, [0] * 3, description="gyro mean rate", unit="rad/s")
    L.add("GYRO_VALID", ["gyro_valid"], INPUT, [0])
    L.add("ACCEL", [f"accel_{a}" for a in "xyz"], INPUT, [0] * 3, description="mean specific force", unit="m/s2")
    L.add("ACCEL_VALID", ["accel_valid"], INPUT, [0])
    L.add("ENC", [f"encoder_{i + 1}" for i in range(n_arm)], INPUT, [0] * n_arm, description="joint angle", unit="rad")
    L.add("ENC_VALID", ["encoders_valid"], INPUT, [0])
    L.add("U", [f"u_{i + 1}" for i in range(n_u)], INPUT, [0] * n_u, description="commanded input (N or N m)")


def _reference_dual(scenario: Scenario, case: str, profile: str):
    """What the native main job builds for a reference-dual case (``studies.main_job.run_case``): the plan, the
    plant copy at the initial mass with its initial state and mass sensitivity, and the dual configuration."""
    from postcapture.dynamics.process_model import NativeProcessModel
    from postcapture.studies.cases import CASES, dual_config
    from postcapture.studies.main_job import initial_state_and_sensitivity
    from postcapture.studies.setup import plan_run

    spec = CASES[case]
    plan = plan_run(scenario, profile=profile, cases=(case,))
    model = NativeProcessModel.for_filters(scenario, variant=spec.variant, name=case)
    theta0 = plan.initial_mass
    model.mass = theta0
    x0, S0 = initial_state_and_sensitivity(model, theta0)
    cfg = dual_config(spec, plan.filter_profile, plan.profile_name, plan.tuning, scenario.n_arm, theta0)
    if cfg.reset_rates:
        raise ValueError(f"case {case}: reset_rates needs the next cycle's gyro sample, which an FMU cycle lacks")
    return plan, model, x0, S0, cfg


def _policy_lines(prefix: str, policy, gate_probability, max_m: int) -> list[str]:
    """A filter's recovery policy and gate as C arrays (what ``FilterBase._policy`` hands the engine)."""
    from postcapture.estimation.filter import _chi2_table

    gate = np.zeros(max_m) if gate_probability is None else _chi2_table(float(gate_probability), max_m + 1)[1:]
    bound = (_chi2_table(float(policy.nis_probability), policy.nis_window * max_m + 1).copy() if policy.nis_window
             else np.zeros(1))
    bound[0] = 0.0  # infinite, never read
    ints = [policy.reject_limit, policy.nis_window, policy.max_recoveries, int(gate_probability is not None), max_m,
            bound.size]
    return [f"static const int {prefix}_I[6] = {_array(ints, lambda v: str(int(v)))};",
            f"static const double {prefix}_D[3] = "
            f"{_array([policy.inflation, policy.gyro_bias_bump, policy.recovery_window])};",
            f"static const double {prefix}_GATE[{gate.size}] = {_array(gate)};",
            f"static const double {prefix}_BOUND[{bound.size}] = {_array(bound)};"]


def _variable_tables(layout: _Layout) -> list[str]:
    """The tables of ``pc_est_data.h`` every estimator FMU reads its variables from (start values, causality,
    tunability, positivity, names), and the header's end."""
    v = layout.variables
    ints = lambda x: str(int(x))  # noqa: E731
    return [
        f"static const double PCE_START[{len(v)}] = {_array([x.start for x in v])};",
        f"static const int PCE_CAUSALITY[{len(v)}] = {_array([x.causality for x in v], ints)};",
        f"static const int PCE_TUNABLE[{len(v)}] = {_array([x.tunable for x in v], ints)};",
        f"static const int PCE_POSITIVE[{len(v)}] = {_array([x.positive for x in v], ints)};",
        f"static const char* const PCE_NAMES[{len(v)}] = {{\n    " + ",\n    ".join(_c_string(x.name) for x in v)
        + "\n};",
        "#endif",
    ]


def _reference_dual_data(scenario: Scenario, case: str, profile: str, guid: str):
    """``(layout, pc_est_data.h text, plan)`` of a reference-dual case."""
    plan, model, x0, S0, cfg = _reference_dual(scenario, case, profile)
    ekf = cfg.attitude == "ekf"
    mass = cfg.mass
    layout = reference_dual_variables(
        model.tangent_arm.size, model.plant.nu, ekf=ekf, q0=model.attitude(x0), R_star=cfg.ekf.R if ekf else
        cfg.mekf.star_covariance, ekf_Q=cfg.ekf.Q, mekf=(cfg.mekf.sigma_v, cfg.mekf.sigma_u), mass_R=mass.R_diag,
        mass_q=(mass.q_start, mass.q_end), mass_q_bias=mass.q_accel_bias if mass.accel_bias else None,
        schedule_end=float(plan.t_grid[-1]))
    return layout, _reference_dual_header(plan, model, x0, S0, cfg, layout, guid), plan


def _reference_dual_header(plan, model, x0, S0, cfg, layout: _Layout, guid: str) -> str:
    """The text of ``pc_est_data.h`` for a reference-dual case."""
    from postcapture.config.schema import orbit_mean_motion
    from postcapture.core.units import DEG
    from postcapture.dynamics.build import build_system
    from postcapture.dynamics.integrators import TABLEAUX
    from postcapture.dynamics.packing import pack
    from postcapture.estimation.filter import RecoveryPolicy
    from postcapture.studies.cases import CASES

    sc = plan.scenario
    packed = pack(build_system(sc, CASES[model.name].variant))
    tab = TABLEAUX[sc.estimation.integrator]
    s = tab.stages
    dt = float(sc.estimation.filter_step)
    n_steps = int(round(dt / model.step))
    ekf = cfg.attitude == "ekf"
    mass = cfg.mass
    smap = mass.sigmoid
    mekf_P0 = np.asarray(cfg.mekf_P0, dtype=float)
    ints = lambda v: str(int(v))  # noqa: E731
    lines = [
        "/* Generated by postcapture.studies.estimator_fmu: the data of one reference-dual estimator FMU. Do not edit. */",
        "#ifndef PC_EST_DATA_H", "#define PC_EST_DATA_H", "#include <math.h>",
        f"#define PCE_GUID {_c_string(guid)}", "#define PCE_SCHEME 2", f"#define PCE_ATT_EKF {int(ekf)}",
        f"#define PCE_NQ {model.nq}", f"#define PCE_NV {model.nv}", f"#define PCE_NP {model.params.size}",
        f"#define PCE_NU {model.plant.nu}", f"#define PCE_NARM {model.tangent_arm.size}",
        f"#define PCE_NZ_PLANT {model.plant.nz}", f"#define PCE_STEP {_num(model.step)}",
        f"#define PCE_NSTEPS {n_steps}", f"#define PCE_DT {_num(dt)}", f"#define PCE_STAGES {s}",
        f"#define PCE_PANEL_MASS {_num(sum(p.mass for p in sc.target.panels))}",
        f"#define PCE_MEAN_MOTION {_num(orbit_mean_motion(sc, 'filters'))}",
        f"#define PCE_FROZEN_JACOBIAN {int(model.jacobian == 'first_step')}",
        f"#define PCE_MASS_NB {3 if mass.accel_bias else 0}", f"#define PCE_MASS_X0 {_num(smap.inverse(plan.initial_mass))}",
        f"#define PCE_MASS_P0 {_num(mass.P0)}", f"#define PCE_MASS_P0_BIAS {_num(mass.P0_accel_bias)}",
        f"#define PCE_SIG_A {_num(smap.a)}", f"#define PCE_SIG_B {_num(smap.b)}", f"#define PCE_SIG_C {_num(smap.c)}",
        f"#define PCE_MASS_TOTAL {int(mass.sensitivity == 'total')}", f"#define PCE_SHIFT_STATE {int(cfg.shift_state)}",
        f"#define PCE_MASS_AWARE_Q {int(cfg.mass_aware_q)}",
        f"#define PCE_MEKF_M {mekf_P0.shape[0]}", f"#define PCE_MEKF_REACQUIRE_BIAS {_num(DEG)}",
        f"#define PCE_NREAL {len(layout.variables)}",
    ]
    lines += [f"#define PCE_VR_{block} {start}" for block, start in layout.blocks.items()]
    if ekf:
        lines += _policy_lines("PCE_POL_ATT", cfg.ekf.recovery, cfg.ekf.gate_probability, 3)
    else:
        lines += _policy_lines("PCE_POL_ATT", RecoveryPolicy(), cfg.mekf.gate_probability, 3)
    lines += _policy_lines("PCE_POL_MASS", mass.recovery, mass.gate_probability, mass.R_diag.size)
    lines += [
        f"static const double PCE_TAB_A[{s}][{s}] = {{" + ", ".join(_array(r) for r in tab.A) + "};",
        f"static const double PCE_TAB_B[{s}] = {_array(tab.b)};",
        f"static const double PCE_TAB_C[{s}] = {_array(tab.c)};",
        f"static const int PCE_IB[{packed.ints.size}] = {_array(packed.ints, ints)};",
        f"static const double PCE_DB[{packed.doubles.size}] = {_array(packed.doubles)};",
        f"static const int PCE_ARM_V[{max(1, model.tangent_arm.size)}] = {_array(model.tangent_arm, ints)};",
        f"static const double PCE_R_ACC[3] = {_array(model.accelerometer_position)};",
        f"static const double PCE_X0[{x0.size}] = {_array(x0)};",
        f"static const double PCE_S0[{S0.size}] = {_array(S0)};",
        f"static const double PCE_P0[{model.params.size}] = {_array(model.params)};",
        f"static const double PCE_EKF_P0[9] = {_array(cfg.ekf.P0)};",
        f"static const double PCE_MEKF_P0[{mekf_P0.size}] = {_array(mekf_P0)};",
    ]
    return "\n".join(lines + _variable_tables(layout)) + "\n"


def _filters(scenario: Scenario, case: str, profile: str):
    """The native main job's filters for a case (its plan, model noise and prior), their noise and the plan."""
    from postcapture.dynamics.process_model import NativeProcessModel
    from postcapture.estimation.filter import _chi2_table
    from postcapture.studies.cases import CASES, dual_config, filter_noise
    from postcapture.studies.robust import build_augmented, with_model_noise
    from postcapture.studies.setup import plan_run

    plan = with_model_noise(plan_run(scenario, profile=profile, cases=(case,)))
    model = NativeProcessModel.for_filters(scenario, variant=CASES[case].variant, name=case)
    q_nominal = model.attitude(model.initial_state())
    aug = build_augmented(plan, model, q_nominal, name=case)
    cfg = dual_config(CASES["dual"], plan.filter_profile, plan.profile_name, plan.tuning, scenario.n_arm,
                      plan.initial_mass)  # the dual's MEKF (the joint case carries its P0 unused)
    R = filter_noise(plan.filter_profile, plan.tuning, scenario.n_arm)
    n_gate = max(3, aug.i_arm.size)
    pol = aug.policy
    gate = _chi2_table(float(aug.gate_probability), n_gate + 1)[1:] if aug.gate_probability is not None else \
        np.zeros(n_gate)
    window = _chi2_table(float(pol.nis_probability), pol.nis_window * n_gate + 1)
    return plan, model, aug, cfg, R, gate, window


def _header(plan, model, aug, cfg, R, gate, window, layout: _Layout, guid: str, dual: bool) -> str:
    """The text of ``pc_est_data.h``."""
    from postcapture.config.schema import orbit_mean_motion
    from postcapture.dynamics.build import build_system
    from postcapture.dynamics.integrators import TABLEAUX
    from postcapture.dynamics.packing import pack
    from postcapture.studies.cases import CASES

    su = aug.setup
    packed = pack(build_system(plan.scenario, CASES[aug.name].variant))
    tab = TABLEAUX[plan.scenario.estimation.integrator]
    pol = aug.policy
    bias = plan.tuning.discretisation_bias
    bias = np.zeros((model.params.size, 0)) if bias is None else np.asarray(bias, dtype=float)
    ints = lambda v: str(int(v))  # noqa: E731
    s = tab.stages
    mekf_P0 = np.asarray(cfg.mekf_P0, dtype=float)
    lines = [
        "/* Generated by postcapture.studies.estimator_fmu: the data of one estimator FMU. Do not edit. */",
        "#ifndef PC_EST_DATA_H", "#define PC_EST_DATA_H", "#include <math.h>",
        f"#define PCE_GUID {_c_string(guid)}", f"#define PCE_DUAL {int(dual)}",
        f"#define PCE_NQ {model.nq}", f"#define PCE_NV {model.nv}", f"#define PCE_NP {model.params.size}",
        f"#define PCE_NU {model.plant.nu}", f"#define PCE_NARM {aug.i_arm.size}", f"#define PCE_NETA {aug.params.size}",
        f"#define PCE_NCAL {su.n_cal}", f"#define PCE_NCON {su.n_consider}", f"#define PCE_N {aug.N}",
        f"#define PCE_STEP {_num(model.step)}", f"#define PCE_DT {_num(plan.scenario.estimation.filter_step)}",
        f"#define PCE_PANEL_MASS {_num(sum(p.mass for p in plan.scenario.target.panels))}",
        f"#define PCE_STAGES {s}", f"#define PCE_NSPEC {aug.params.spec.size}",
        f"#define PCE_POL_REJECT {pol.reject_limit}", f"#define PCE_POL_WINDOW {pol.nis_window}",
        f"#define PCE_POL_MAXREC {pol.max_recoveries}", f"#define PCE_POL_INFL {_num(pol.inflation)}",
        f"#define PCE_POL_BUMP {_num(pol.gyro_bias_bump)}", f"#define PCE_POL_RECWIN {_num(pol.recovery_window)}",
        f"#define PCE_GATED {int(aug.gate_probability is not None)}",
        f"#define PCE_MEKF_M {mekf_P0.shape[0]}", f"#define PCE_MEKF_REACQUIRE_BIAS {_num(np.deg2rad(1.0))}",
        f"#define PCE_NBIAS_T {bias.shape[1]}", f"#define PCE_NREAL {len(layout.variables)}",
        f"#define PCE_MEAN_MOTION {_num(orbit_mean_motion(plan.scenario, 'filters'))}",
        f"#define PCE_FROZEN_JACOBIAN {int(model.jacobian == 'first_step')}",
    ]
    lines += [f"#define PCE_VR_{block} {start}" for block, start in layout.blocks.items()]
    w = window.copy()
    w[0] = 0.0  # never read (a window holds at least one degree of freedom per update)
    lines += [
        f"static const double PCE_TAB_A[{s}][{s}] = {{" + ", ".join(_array(r) for r in tab.A) + "};",
        f"static const double PCE_TAB_B[{s}] = {_array(tab.b)};",
        f"static const double PCE_TAB_C[{s}] = {_array(tab.c)};",
        f"static const int PCE_IB[{packed.ints.size}] = {_array(packed.ints, ints)};",
        f"static const double PCE_DB[{packed.doubles.size}] = {_array(packed.doubles)};",
        f"static const int PCE_ARM_V[{max(1, aug.i_arm.size)}] = {_array(aug.i_arm, ints)};",
        f"static const int PCE_SPEC[{aug.params.spec.size}] = {_array(aug.params.spec, ints)};",
        f"static const double PCE_P_NOM[{model.params.size}] = {_array(aug.params.p_nominal)};",
        f"static const double PCE_R_ACC[3] = {_array(aug.r_accel)};",
        f"static const double PCE_X0[{su.x0.size}] = {_array(su.x0)};",
        f"static const double PCE_DX0[{su.dx_shift.size}] = {_array(su.dx_shift)};",
        f"static const double PCE_ETA0[{max(1, su.eta0.size)}] = {_array(su.eta0)};",
        f"static const double PCE_P0[{su.P0.size}] = {_array(su.P0)};",
        f"static const double PCE_GATE[{gate.size}] = {_array(gate)};",
        f"static const double PCE_WINDOW_BOUND[{w.size}] = {_array(w)};",
        f"static const double PCE_MEKF_P0[{mekf_P0.size}] = {_array(mekf_P0)};",
        f"static const double PCE_BIAS[{max(1, bias.size)}] = {_array(bias if bias.size else [0.0])};",
    ]
    return "\n".join(lines + _variable_tables(layout)) + "\n"


def _model_description(layout: _Layout, ident: str, guid: str, case: str, scenario: Scenario, period: float,
                       sources: list[str]) -> str:
    from postcapture._version import __version__

    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": f"{scenario.name} {case} estimator", "guid": guid,
        "description": f"postcapture {case} estimator of scenario {scenario.name}: one doStep is one filter cycle",
        "generationTool": f"postcapture {__version__}", "variableNamingConvention": "structured",
        "numberOfEventIndicators": "0"})
    cs = ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": ident, "canHandleVariableCommunicationStepSize": "false", "canGetAndSetFMUstate": "true",
        "canSerializeFMUstate": "true", "providesDirectionalDerivative": "false", "canNotUseMemoryManagementFunctions":
        "true"})
    files = ET.SubElement(cs, "SourceFiles")
    for name in sources:
        ET.SubElement(files, "File", {"name": name})
    ET.SubElement(root, "DefaultExperiment", {"startTime": "0.0", "stopTime": repr(float(scenario.simulation.duration)),
                                              "stepSize": repr(float(period))})
    mv = ET.SubElement(root, "ModelVariables")
    outputs = []
    for vr, v in enumerate(layout.variables):
        attrs = {"name": v.name, "valueReference": str(vr)}
        if v.description:
            attrs["description"] = v.description
        if v.causality == INPUT:
            attrs.update(causality="input", variability="discrete")
            start = True
        elif v.causality == PARAMETER:
            attrs.update(causality="parameter", variability="tunable" if v.tunable else "fixed")
            start = True
        else:
            attrs.update(causality="output", variability="discrete", initial="calculated")
            start = False
            outputs.append(vr + 1)
        sv = ET.SubElement(mv, "ScalarVariable", attrs)
        real = {"start": repr(v.start)} if start else {}
        if v.unit:
            real["unit"] = v.unit
        ET.SubElement(sv, "Real", real)
    ms = ET.SubElement(root, "ModelStructure")
    out = ET.SubElement(ms, "Outputs")
    for index in outputs:
        ET.SubElement(out, "Unknown", {"index": str(index)})
    init = ET.SubElement(ms, "InitialUnknowns")
    for index in outputs:
        ET.SubElement(init, "Unknown", {"index": str(index)})
    units = sorted({v.unit for v in layout.variables if v.unit})
    if units:
        defs = ET.Element("UnitDefinitions")
        for u in units:  # with SI base units, which masters compare across a connection (OMSimulator does)
            base = {**UNITS, "rad2": {"rad": 2}}.get(u)
            unit = ET.SubElement(defs, "Unit", {"name": u})
            if base is not None:
                ET.SubElement(unit, "BaseUnit", {k: str(e) for k, e in base.items()})
        root.insert(1, defs)  # after CoSimulation (FMI 2.0 schema order)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def export_estimator_fmu(scenario: Scenario | str | Path, out_path: str | Path, *, case: str = "joint",
                         profile: str = "reference", model_identifier: str | None = None,
                         progress=None, fmi_version: int = 2) -> EstimatorExport:
    """Export a recommended estimation case of a scenario as an FMI 2.0 or 3.0 co-simulation FMU.

    Parameters
    ----------
    scenario : Scenario, str or Path
        A scenario, or a built-in name or TOML path.
    out_path : str or Path
        The ``.fmu`` to write.
    case : {"joint", "dual", "ekf_flexible", "mekf_flexible"}
        The scheme: a recommended one (:mod:`postcapture.estimation.schemes`) or the reference's dual scheme
        with its EKF or MEKF on the flexible model (:mod:`postcapture.estimation.dual`).
    profile : {"reference", "realistic"}
        The sensor profile whose tuning the FMU carries (its defaults; tunable).
    model_identifier : str, optional
        Library name (default ``<scenario>_<case>_estimator``).
    progress : callable(str), optional
    fmi_version : {2, 3}
        FMI 2.0 or 3.0 co-simulation: the same filters, variables and checks.

    Returns
    -------
    EstimatorExport

    Raises
    ------
    ValueError
        For a case that has no estimator FMU, or an FMI version other than 2 or 3.
    FMIError
        When the C compiler is missing or compilation fails.
    """
    from postcapture.config import load_scenario
    from postcapture.dynamics.compiled import source_files
    from postcapture.fmi.export.compiler import compile_library, zip_fmu
    from postcapture.fmi.export.exporter import _identifier
    from postcapture.fmi.export.versions import VERSIONS

    if case not in ESTIMATOR_CASES:
        raise ValueError(f"case: expected one of {', '.join(ESTIMATOR_CASES)}, found {case!r}")
    if fmi_version not in _WRAPPERS:
        raise ValueError(f"fmi_version: expected 2 or 3, found {fmi_version!r}")
    version = VERSIONS[fmi_version]
    say = progress or (lambda msg: None)
    fmpy = import_fmpy()
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    out_path = check_output_file(out_path)
    ident = _identifier(model_identifier or f"{scenario.name}_{case}_estimator")
    from postcapture._version import __version__

    key = hashlib.sha256("|".join([scenario.model_dump_json(), case, profile, ident, __version__]
                                  + ([] if fmi_version == 2 else [version.name])).encode())
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "postcapture-estimator:" + key.hexdigest())) + "}"
    say("building the filters (the plan, its model noise and the prior)")
    if case in REFERENCE_DUAL_CASES:
        layout, header, plan = _reference_dual_data(scenario, case, profile, guid)
    else:
        plan, model, aug, cfg, R, gate, window = _filters(scenario, case, profile)
        dual = case == "dual"
        sig = {"gyro": float(np.sqrt(R["gyro"][0, 0])), "accelerometer": float(np.sqrt(R["accelerometer"][0, 0])),
               "encoders": float(np.sqrt(R["encoders"][0, 0])), "gyro_walk": aug.tuning.sigma_gyro_bias_walk,
               "accel_walk": aug.tuning.sigma_accel_bias_walk}
        q0 = model.attitude(model.initial_state())
        layout = estimator_variables(aug.i_arm.size, model.plant.nu, model.param_names, dual=dual, q0=q0,
                                     R_star=R["star_tracker"], sigmas=sig, model_noise=aug.setup.q_noise,
                                     mekf=(cfg.mekf.sigma_v, cfg.mekf.sigma_u))
        header = _header(plan, model, aug, cfg, R, gate, window, layout, guid, dual)
    with scratch_folder("postcapture_estimator_fmu") as tmp:
        root = Path(tmp) / "fmu"
        src = root / "sources"
        src.mkdir(parents=True)
        say("writing the sources")
        (src / "pc_est_data.h").write_text(header)
        for name, text in source_files().items():
            (src / name).write_text(text)
        runtime = resources.files("postcapture.fmi") / "csrc"
        for name in (*_RUNTIME, _CYCLE[case], _WRAPPERS[fmi_version], version.wrapper_common):
            (src / name).write_text((runtime / name).read_text())
        c_code = Path(fmpy.__file__).parent / "c-code"
        for name in version.headers:
            shutil.copy(c_code / name, src / name)
        say("compiling the shared library")
        compile_library(src, Path(tmp) / "build", root / "binaries" / version.binary_folder() / (ident + ".so"),
                        fmu=str(out_path))
        sources = sorted(p.name for p in src.glob("*.c"))
        period = plan.scenario.estimation.filter_step
        if fmi_version == 3:
            from postcapture.studies.estimator_fmu3 import write_description3

            write_description3(root, layout, ident, guid, case, scenario, period, sources)
        else:
            (root / "modelDescription.xml").write_text(
                _model_description(layout, ident, guid, case, scenario, period, sources))
        zip_fmu(root, out_path)
    return EstimatorExport(out_path, case, profile, guid, float(plan.scenario.estimation.filter_step),
                           tuple(layout.variables), version.name)
