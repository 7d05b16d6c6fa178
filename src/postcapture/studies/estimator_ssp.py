"""``export_estimator_ssp``: the plant FMU and an estimator FMU composed in one SSP archive.

The reference placed its filter FMUs next to the system model and wired the model's sensor outputs into
them (its "overall system structure"). This is that scheme as an SSP 1.0 archive, runnable in OMSimulator:
``resources/plant.fmu`` is the scenario's plant (:func:`postcapture.fmi.export_fmu`, FMI 2.0 co-simulation)
and ``resources/estimator.fmu`` the recommended case's estimator
(:func:`postcapture.studies.estimator_fmu.export_estimator_fmu`), both built for the same scenario.

What is connected (plant output -> estimator input):

- ``q_BN_w/x/y/z`` -> ``star_q_w/x/y/z`` (the star tracker);
- ``gyro_mean_x/y/z`` -> ``gyro_x/y/z`` (the gyro: the mean body rate over the plant's last step);
- ``accel_mean_x/y/z`` -> ``accel_x/y/z`` (the accelerometer: the mean specific force over it);
- ``arm_q_i`` -> ``encoder_i`` (the arm's encoders);
- the system's own inputs ``force_x/y/z``, ``torque_x/y/z`` and ``joint_i`` (commanded force, torque and
  joint torques, zero unless a master sets them) feed both the plant's inputs of the same name and the
  estimator's ``u_1 .. u_nu``, in that order: the filter knows what was commanded;
- ``star_valid``, ``gyro_valid``, ``accel_valid`` and ``encoders_valid`` are bound to 1 (every sample valid).

The plant's parameter inputs (``target.*``, the factors), its state reset (``x_corr``, ``reset``) and its
Jacobian request stay at their start values: the plant is the truth, nothing flows back into it.

The sensors and the master's semantics:

- the plant's sensor outputs are the native main job's sensors (``studies/sensing.py``), noise-free and
  bias-free: the gyro's *mean rate* and the accelerometer's *mean specific force* (less the tidal field of
  the orbit the plant flies, if any) over the plant's last step, computed in the FMU by the engine's own
  functions; the star tracker (``q_BN``) and the encoders (``arm_q``) are its state at the step's end;
- OMSimulator's fixed-step master (``oms_solver_wc_ma``, ``SystemWC::doStep``) is a Jacobi scheme and has no
  other ordering: every FMU steps from ``t_k`` to ``t_k+1`` with the inputs set at ``t_k``, then every
  connection passes the outputs at ``t_k+1`` on. The estimator's cycle ``[t_k, t_k+1]`` reads its inputs
  before it and expects the sensors of that cycle (the star tracker and the encoders at its end, the means
  over it): a plant at the master's time would hand it those of the cycle before. So the plant FMU is
  exported with ``lead`` = the filter's period (:func:`postcapture.fmi.export_fmu`): it flies ``[t0, t1]``
  when leaving initialisation and stays one period ahead of the master, so that at the master's ``t_k`` its
  outputs are the sensors of ``[t_k, t_k+1]``. The plant's own results in the archive's output are thus those
  at the master's time plus one period. The commanded inputs (zero here) reach the estimator for the cycle
  ``[t_k, t_k+1]`` and the plant for its ``[t_k+1, t_k+2]``: one cycle apart.

The communication step is the filter's period (the estimator refuses any other step); the plant integrates
each in its own internal steps. OMSimulator accumulates its time (``t += step``), so after ``n`` cycles it
stands a few 1e-15 s short of ``n * step`` and would ask for a last step of that remainder, which the
estimator refuses: run it with ``--stopTime`` equal to the accumulated time, :attr:`SSPExport.stop_time`
(also the archive's default experiment).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from postcapture.config.schema import Scenario
from postcapture.core.errors import FMIError
from postcapture.fmi.export.ssp import SSPComponent, SSPConnection, fmu_variables, write_ssp
from postcapture.io import check_output_file, scratch_folder

__all__ = ["SSPExport", "export_estimator_ssp", "scheme_connections", "accumulated_time"]

_FLAGS = ("star_valid", "gyro_valid", "accel_valid", "encoders_valid")


@dataclass(frozen=True)
class SSPExport:
    """What :func:`export_estimator_ssp` built.

    Attributes
    ----------
    path : Path
        The ``.ssp`` archive.
    case, profile : str
        The estimator's case and sensor profile.
    period : float
        The communication step: the filter's period (s).
    n_cycles : int
        Filter cycles in the scenario's duration.
    stop_time : float
        OMSimulator's time after ``n_cycles`` steps (``t += period`` each): the ``--stopTime`` to give it.
    connections : tuple of SSPConnection
    bindings : dict
        The estimator inputs held constant.
    """

    path: Path
    case: str
    profile: str
    period: float
    n_cycles: int
    stop_time: float
    connections: tuple
    bindings: dict


def accumulated_time(step: float, n: int) -> float:
    """A master's time after ``n`` steps when it adds ``step`` each time (OMSimulator's fixed-step master)."""
    t = 0.0
    for _ in range(n):
        t += step
    return t


def _numbered(variables: dict, prefix: str, causality: str) -> list[str]:
    out, i = [], 1
    while variables.get(f"{prefix}{i}", ("",))[0] == causality:
        out.append(f"{prefix}{i}")
        i += 1
    return out


def scheme_connections(plant: dict, estimator: dict) -> tuple[list[SSPConnection], dict, dict]:
    """The connections of the plant and the estimator (their variables ``name -> (causality, unit)``), the
    system's inputs (``name -> unit``) and the estimator's constant inputs.

    Raises
    ------
    FMIError
        When the plant's encoders or commanded inputs do not match the estimator's in number.
    """
    cons = [SSPConnection("plant", f"q_BN_{a}", "estimator", f"star_q_{a}") for a in "wxyz"]
    cons += [SSPConnection("plant", f"gyro_mean_{a}", "estimator", f"gyro_{a}") for a in "xyz"]
    cons += [SSPConnection("plant", f"accel_mean_{a}", "estimator", f"accel_{a}") for a in "xyz"]
    encoders = _numbered(estimator, "encoder_", "input")
    joints = _numbered(plant, "arm_q_", "output")
    if len(encoders) != len(joints):
        raise FMIError(f"encoders: the estimator reads {len(encoders)} joint angles, the plant outputs "
                       f"{len(joints)} (arm_q_*)")
    cons += [SSPConnection("plant", j, "estimator", e) for j, e in zip(joints, encoders)]
    commanded = [f"force_{a}" for a in "xyz"] + [f"torque_{a}" for a in "xyz"]
    commanded += _numbered(plant, "joint_", "input")
    u = _numbered(estimator, "u_", "input")
    if len(u) != len(commanded) or any(plant.get(n, ("",))[0] != "input" for n in commanded):
        raise FMIError(f"commanded inputs: the estimator takes {len(u)} (u_*), the plant "
                       f"{sum(plant.get(n, ('',))[0] == 'input' for n in commanded)} (force, torque, joint_*)")
    system_inputs = {name: plant[name][1] for name in commanded}
    for name, ui in zip(commanded, u):
        cons += [SSPConnection("", name, "plant", name), SSPConnection("", name, "estimator", ui)]
    flags = {f: 1.0 for f in _FLAGS if f != "encoders_valid" or encoders}
    return cons, system_inputs, flags


def export_estimator_ssp(scenario: Scenario | str | Path, out_path: str | Path, *, case: str = "joint",
                         profile: str = "reference", variant: str = "flexible", panel_segments: int | None = None,
                         directional_derivatives: bool = True, step_jacobian: bool = True,
                         progress=None) -> SSPExport:
    """Export the plant and a recommended case's estimator of a scenario, connected, as an SSP 1.0 archive.

    Parameters
    ----------
    scenario : Scenario, str or Path
        A scenario, or a built-in name or TOML path.
    out_path : str or Path
        The ``.ssp`` to write.
    case : {"joint", "dual"}
        The estimator's scheme.
    profile : {"reference", "realistic"}
        The sensor profile whose tuning the estimator carries.
    variant, panel_segments, directional_derivatives, step_jacobian
        The plant FMU's options (:func:`postcapture.fmi.export_fmu`; its ``lead`` is the filter's period).
    progress : callable(str), optional

    Returns
    -------
    SSPExport

    Raises
    ------
    ValueError
        For a case that is not a recommended scheme, or an output that is not a ``.ssp`` file.
    FMIError
        When an FMU cannot be built or the two do not fit together.
    """
    from postcapture.config import load_scenario
    from postcapture.fmi import export_fmu
    from postcapture.studies.estimator_fmu import OUTPUT, export_estimator_fmu

    say = progress or (lambda msg: None)
    out_path = Path(out_path)
    if out_path.suffix.lower() != ".ssp":
        raise ValueError(f"out_path: an SSP archive ends in .ssp (OMSimulator reads it by that suffix), "
                         f"found {out_path.name!r}")
    out_path = check_output_file(out_path)
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    with scratch_folder("postcapture_ssp") as tmp:
        say(f"exporting the {case} estimator FMU")
        est = export_estimator_fmu(scenario, Path(tmp) / "estimator.fmu", case=case, profile=profile)
        say("exporting the plant FMU (one filter period ahead of the master)")
        plant = export_fmu(scenario, Path(tmp) / "plant.fmu", variant=variant, fmi_version=2,
                           directional_derivatives=directional_derivatives, step_jacobian=step_jacobian,
                           panel_segments=panel_segments, lead=est.period)
        _, plant_vars, _ = fmu_variables(plant.path)
        _, est_vars, _ = fmu_variables(est.path)
        cons, system_inputs, flags = scheme_connections(plant_vars, est_vars)
        n = max(1, int(round(float(scenario.simulation.duration) / est.period)))
        stop = accumulated_time(est.period, n)
        results = [f"estimator.{v.name}" for v in est.variables if v.causality == OUTPUT]
        results += [f"plant.{c.start_connector}" for c in cons if c.start_element == "plant"] + list(system_inputs)
        say("writing the SSP archive")
        write_ssp(out_path, name="scheme", step=est.period, stop=stop, system_inputs=system_inputs,
                  components=[SSPComponent("plant", plant.path), SSPComponent("estimator", est.path, flags)],
                  connections=cons, results=results)
    return SSPExport(out_path, case, profile, est.period, n, stop, tuple(cons), flags)
