"""The short Python API: one call per job, re-exported by ``postcapture`` itself.

>>> import postcapture as pc
>>> scenario = pc.load_scenario("envisat")
>>> traj = pc.simulate(scenario, duration=2.0)
>>> traj.to_xarray()["force_x"].attrs["units"]
'N'

Each function takes a scenario object, a built-in name or a TOML path, and calls the one library
function that does the work (named in its docstring), so the deeper modules stay available for
everything else. Nothing heavy is imported until a function is called.

Every function that takes time reports through one callback signature, ``progress(task, fraction)``:
``task`` (str) names what is under way (``"truth simulation"``, a case, ``"runs"``, ``"calibration"``,
``"fmu export"``) and ``fraction`` (float in [0, 1]) how far it is; 1.0 means that task is done.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

Progress = Callable[[str, float], None]
"""``progress(task, fraction)``: the one progress callback of the package (see the module docstring)."""

__all__ = ["load_scenario", "simulate", "run", "RunResult", "campaign", "calibrate_panel", "export_fmu", "Progress"]


def load_scenario(source="envisat"):
    """A validated scenario: a built-in name (``"envisat"``) or a TOML file.

    Same as :func:`postcapture.config.load_scenario`.

    Parameters
    ----------
    source : str or Path, optional
        Built-in name or path (default ``"envisat"``).

    Returns
    -------
    Scenario

    Raises
    ------
    ScenarioError
        Listing every problem of the file, as ``path: expected ..., found ...``.

    Examples
    --------
    >>> scenario = load_scenario("envisat")
    >>> scenario.target.mass
    7827.9
    """
    from postcapture.config import Scenario
    from postcapture.config import load_scenario as load

    return source if isinstance(source, Scenario) else load(source)


def simulate(scenario="envisat", *, variant: str = "flexible", duration: float | None = None,
             panel_segments: int | None = None, damping: bool = True, excitation: bool = True,
             integrator: str | None = None, step: float | None = None, sample_period: float | None = None,
             progress: Progress | None = None):
    """Simulate a scenario's truth; see :func:`postcapture.dynamics.simulate.simulate` for the options.

    Parameters
    ----------
    scenario : Scenario, str or Path, optional
        Default ``"envisat"``.
    variant : {"flexible", "stiff", "rigid"}, optional
    duration : float, optional
        Seconds (default: the scenario's).
    panel_segments : int, optional
    damping, excitation : bool, optional
    integrator : {"sdirk4", "sdirk3", "sdirk2", "rk4"}, optional
    step, sample_period : float, optional
        Seconds.
    progress : callable(task, fraction), optional
        Called with ``("truth simulation", fraction)``.

    Returns
    -------
    Trajectory
        ``traj["q_BN"]`` and the other outputs (time last); ``traj.to_xarray()`` for a dataset;
        ``traj.to_netcdf(path)``.

    Examples
    --------
    >>> traj = simulate("envisat", duration=1.0)
    >>> traj  # doctest: +ELLIPSIS
    Trajectory(scenario 'envisat', flexible model, 11 samples over 1 s, 25 DoF; outputs q_BN, ...)
    >>> traj["q_BN"].shape
    (4, 11)
    """
    from postcapture.dynamics.simulate import simulate as run_truth

    report = None if progress is None else (lambda fraction: progress("truth simulation", fraction))
    return run_truth(load_scenario(scenario), variant=variant, duration=duration, panel_segments=panel_segments,
                     damping=damping, excitation=excitation, integrator=integrator, step=step,
                     sample_period=sample_period, progress=report)


class RunResult:
    """What :func:`run` returns: the table, the histories as xarray or pandas, the files.

    Attributes
    ----------
    result : MainJobResult
        Everything the main job produced (truth trajectory, per-case histories, bounds).
    summary : dict
        The JSON document ``postcapture run --json`` prints.
    """

    def __init__(self, result):
        from postcapture.studies.results import run_summary

        self.result = result
        self.summary = run_summary(result)

    @property
    def cases(self) -> tuple[str, ...]:
        """Names of the cases run."""
        return tuple(self.result.cases)

    @property
    def table(self) -> str:
        """The table ``postcapture run`` prints (80 columns)."""
        from postcapture.report.table import results_table

        return results_table(self.summary)

    def to_pandas(self):
        """One row per case, one column per figure of merit (the table's numbers, full precision).

        Returns
        -------
        pandas.DataFrame
            Indexed by case; columns such as ``mass_error_kg``, ``mass_sigma_kg``, ``settle_1pct_s``,
            ``attitude_rms_arcsec``, ``nees_mean``, ``success``, ``message``, ``wall_s``.
        """
        import pandas as pd

        rows = {name: {k: v for k, v in m.items() if not isinstance(v, (list, dict))}
                for name, m in self.summary["cases"].items()}
        frame = pd.DataFrame.from_dict(rows, orient="index")
        frame.index.name = "case"
        return frame

    def to_xarray(self):
        """Every history (truth and estimates, time last) as an :class:`xarray.Dataset` with units.

        The same dataset ``results.nc`` holds; see :func:`postcapture.studies.results.to_dataset`.
        """
        from postcapture.studies.results import to_dataset

        return to_dataset(self.result)

    def figures(self) -> dict:
        """The main job's figures, keyed by file stem (see :data:`postcapture.report.figures.FIGURES`)."""
        from postcapture.report.figures import main_job_figures

        return main_job_figures(self.to_xarray())

    def write(self, out_dir, *, figures: bool = True, fmt: str = "png", dpi: int | None = None) -> dict:
        """Write ``results.nc``, ``summary.json``, ``table.txt``, the figures (``fmt``: png, pdf or svg) and
        ``report.md``; returns the paths."""
        from postcapture.studies.results import write_results

        return write_results(self.result, out_dir, figures=figures, fmt=fmt, dpi=dpi)

    def __repr__(self) -> str:
        s = self.summary
        return (f"RunResult(scenario {s['scenario']!r}, {s['profile']} profile, seed {s['seed']}, "
                f"{s['duration_s']:g} s; cases {', '.join(self.cases)})")


def _truth(nominal, truth):
    """A :class:`~postcapture.dynamics.truth.TruthModel` from ``truth``: None (the nominal scenario), a seed
    (a draw from the scenario's priors), a scenario, a name or a path (another scenario of the same structure)."""
    from postcapture.dynamics.truth import TruthModel, check_priors, draw_truth, truth_from_scenario

    if truth is None or isinstance(truth, TruthModel):
        return truth
    if isinstance(truth, int) and not isinstance(truth, bool):
        check_priors(nominal)
        return draw_truth(nominal, truth)
    return truth_from_scenario(nominal, load_scenario(truth), str(truth))


def run(scenario="envisat", *, truth=None, profile: str = "reference", duration: float | None = None,
        cases: Sequence[str] | None = None, seed: int | None = None, initial_mass_error: float | None = None,
        plant: str = "native", mapping: str | Path | None = None, workers: int = 2, crlb: bool = True,
        progress: Progress | None = None) -> RunResult:
    """The main job: truth, sensors, the estimation cases, metrics (as ``postcapture run``).

    Calls :func:`postcapture.studies.main_job.run_main_job`.

    Parameters
    ----------
    scenario : Scenario, str or Path, optional
        The filters' (nominal) scenario; default ``"envisat"``.
    truth : int, Scenario, str, Path or TruthModel, optional
        The simulated world: a seed draws it from the scenario's ``[uncertainty]``; a scenario (object,
        name or path) of the same structure is taken as is; None is the nominal scenario itself.
    profile : {"reference", "realistic"}, optional
        Sensor profile and tuning.
    duration : float, optional
        Seconds (default: the scenario's).
    cases : sequence of str, optional
        Case names (default: the recommended dual and joint schemes and the reference's four).
    seed : int, optional
        Sensor-noise seed (default: the scenario's).
    initial_mass_error : float, optional
        Added to the nominal mass to start the filters (kg; default: the scenario's).
    plant : str, optional
        ``"native"`` or ``"fmu:PATH"``.
    mapping : str or Path, optional
        The FMU's variable mapping (default: its own).
    workers : int, optional
        Processes for the cases.
    crlb : bool, optional
        Also compute the mass Cramer-Rao bound.
    progress : callable(task, fraction), optional
        Called with ``("truth simulation", f)``, then each case's name (and ``"crlb"``) with its fraction.

    Returns
    -------
    RunResult

    Examples
    --------
    >>> result = run("envisat", duration=5.0, cases=["joint"], crlb=False, workers=1)
    >>> bool(result.to_pandas().loc["joint", "success"])
    True
    >>> result.to_xarray()["mass_est"].dims
    ('case', 'time')
    """
    from postcapture.studies.cases import DEFAULT_CASES
    from postcapture.studies.main_job import run_main_job

    nominal = load_scenario(scenario)
    result = run_main_job(nominal, truth=_truth(nominal, truth), profile=profile, duration=duration,
                          cases=tuple(cases) if cases is not None else DEFAULT_CASES, seed=seed,
                          initial_mass_error=initial_mass_error, plant=plant,
                          mapping=None if mapping is None else str(mapping), workers=workers, crlb=crlb,
                          progress=progress)
    return RunResult(result)


def campaign(scenario="envisat", *, runs: int, dispersed: bool = False, truth=None, profile: str = "realistic",
             cases: Sequence[str] = ("dual", "joint"), duration: float | None = None,
             initial_mass_error: float | None = None, scheduler: str | None = None, workers: int = 2,
             out: str | Path | None = None, fresh: bool = False, crlb: bool = True,
             progress: Progress | None = None):
    """A Monte Carlo campaign on Dask (as ``postcapture campaign``).

    Calls :func:`postcapture.studies.montecarlo.run_campaign`.

    Parameters
    ----------
    scenario : Scenario, str or Path, optional
        The filters' (nominal) scenario, its priors and seed.
    runs : int
        Number of runs.
    dispersed : bool, optional
        Draw each run's truth from the scenario's ``[uncertainty]``.
    truth : Scenario, str, Path or TruthModel, optional
        One truth for every run (not with ``dispersed``).
    profile, cases, duration, initial_mass_error : optional
        As for :func:`run`.
    scheduler : str, optional
        A running Dask scheduler (``tcp://host:port``); a local cluster on 127.0.0.1 otherwise.
    workers : int, optional
        Worker processes of the local cluster (0: in this process, without Dask).
    out : str or Path, optional
        Folder of the saved runs: a campaign started again there resumes.
    fresh : bool, optional
        Discard saved runs instead of resuming.
    crlb : bool, optional
        Also compute the mass bounds.
    progress : callable(task, fraction), optional
        Called with ``("runs", done / runs)`` as runs finish.

    Returns
    -------
    CampaignResult
        ``.table``, ``.summary()``, ``.to_pandas()``, ``.to_xarray()`` (run x case x time), ``.figures()``,
        ``.write(folder)``, ``.runs``.

    Examples
    --------
    >>> res = campaign("envisat", runs=2, dispersed=True, cases=["dual"], duration=3.0, workers=0, crlb=False)
    >>> res.summary()["runs"], sorted(res.to_xarray()["mass_error"].dims)
    (2, ['case', 'run', 'time'])
    """
    from postcapture.studies.montecarlo import run_campaign

    nominal = load_scenario(scenario)
    return run_campaign(nominal, runs=runs, dispersed=dispersed, truth=_truth(nominal, truth), profile=profile,
                        cases=tuple(cases), duration=duration, initial_mass_error=initial_mass_error,
                        scheduler=scheduler, workers=workers, out=out, fresh=fresh, crlb=crlb, progress=progress)


def calibrate_panel(panel="envisat", *, segments: int = 5, weights: Sequence[float] = (1.0, 10.0, 0.1),
                    reference="fem", progress: Progress | None = None):
    """Calibrate a panel's lumped chain against a plate FEM (as ``postcapture panel calibrate``).

    Calls :func:`postcapture.panels.calibrate`, where the other options are.

    Parameters
    ----------
    panel : str, Path or tuple, optional
        ``"envisat"``, ``"chaser"``, or a panel TOML file.
    segments : int, optional
        Rigid segments of the chain.
    weights : sequence of float, optional
        Mode-shape weights, one fit each.
    reference : {"fem"} or Path, optional
        The built-in plate FEM, or a Nastran OP2 file.
    progress : callable(task, fraction), optional
        Called with ``("calibration", done / total)`` after each step.

    Returns
    -------
    CalibrationResult
        ``.tables()``, ``.runs[label]``, ``.toml_fragment(label)``, ``.write(folder)``.

    Examples
    --------
    >>> cal = calibrate_panel("envisat", weights=[0.1])
    >>> run = cal.runs["w=0.1"]
    >>> abs(run.peak_hz / cal.fem_peak_hz - 1) < 0.02
    True
    """
    from postcapture.panels import calibrate

    report = None if progress is None else (lambda done, total, message: progress("calibration", done / total))
    return calibrate(panel, segments=segments, weights=tuple(weights), reference=reference, progress=report)


def export_fmu(scenario, path, *, variant: str = "flexible", fmi_version: int = 2, directional_derivatives: bool = True,
               step_jacobian: bool = True, panel_segments: int | None = None,
               progress: Progress | None = None):
    """Export a scenario's plant as an FMI 2.0 or 3.0 co-simulation FMU (compiled C, no Python inside).

    Calls :func:`postcapture.fmi.export_fmu`, where the other options are.

    Parameters
    ----------
    scenario : Scenario, str or Path
    path : str or Path
        The ``.fmu`` file; the variable mapping is written next to it.
    variant : {"flexible", "stiff", "rigid"}, optional
    fmi_version : {2, 3}, optional
        FMI 2.0 or 3.0 co-simulation (the same plant and variables).
    directional_derivatives : bool, optional
        Provide directional derivatives.
    step_jacobian : bool, optional
        Add the exact step and measurement Jacobian outputs.
    panel_segments : int, optional
    progress : callable(task, fraction), optional
        Called with ``("fmu export", fraction)`` at each of its four phases and at the end.

    Returns
    -------
    ExportReport
        ``.path``, ``.mapping_path``, ``.n_states``, ``.seconds``, ...
    """
    from postcapture.fmi import export_fmu as export

    phases = []

    def report(message):
        phases.append(message)
        progress("fmu export", min(len(phases) - 1, _EXPORT_PHASES) / _EXPORT_PHASES)

    result = export(load_scenario(scenario), path, variant=variant, fmi_version=fmi_version,
                    directional_derivatives=directional_derivatives,
                    step_jacobian=step_jacobian, panel_segments=panel_segments,
                    progress=None if progress is None else report)
    if progress is not None:
        progress("fmu export", 1.0)
    return result


_EXPORT_PHASES = 4  # building the plant, writing the sources, compiling, writing the description
