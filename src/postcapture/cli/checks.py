"""The validation pass: everything a command was given, checked before any work starts.

Each command calls its function here first. A function loads the scenario, applies the options to it
the way the command will (so the schema judges them: ``--step`` must divide the sample period, the
segment cap holds for ``--panel-segments``), asks the library's own planners (:func:`plan_run` for the
main job), checks the output paths (a regular file or folder we may write, see :mod:`postcapture.io`),
the FMU and mapping files, and the resources the work would need (:mod:`postcapture.config.limits`).

Problems are collected, each naming the option (or the scenario field) it concerns, and reported at
once: :class:`~postcapture.core.errors.InputError`; a scenario file that is the only problem keeps its
own :class:`~postcapture.core.errors.ScenarioError`. A run too large for the resource limits raises
:class:`~postcapture.core.errors.ResourceLimitError`.

To check a new option: add a line to :data:`OPTION_FIELDS` when it overrides a scenario field, or one
call of a :class:`Pass` method (``output_file``, ``output_folder``, ``input_file``, ``fmu``, ``add``).
"""

from __future__ import annotations

import os
from pathlib import Path

from postcapture.core.errors import InputError, OutputPathError, Problem, ScenarioError

__all__ = ["OPTION_FIELDS", "Pass", "simulate", "run", "campaign", "modes", "fmu_export", "fmu_info", "truth",
           "panel_calibrate", "bench", "default_simulate_out"]

OPTION_FIELDS = {
    # option: (scenario field it overrides, attribute of the parsed arguments)
    "--step": ("simulation.step", "step"),
    "--duration": ("simulation.duration", "duration"),
    "--integrator": ("simulation.integrator", "integrator"),
}
"""Options that override a scenario field; the schema validates them with the rest of the scenario."""

PLAN_FIELDS = {"duration": "--duration", "initial_mass_error": "--initial-mass-error", "cases": "--cases",
               "plant": "--plant", "profile": "--profile", "seed": "--seed"}
"""Settings of :func:`postcapture.studies.setup.plan_run` and the options that give them."""


class Pass:
    """The problems found in one command's inputs.

    Parameters
    ----------
    command : str
        The command (for the message head), e.g. ``"run"``.
    """

    def __init__(self, command: str):
        self.command = command
        self.problems: list[Problem] = []
        self.scenario_error: ScenarioError | None = None

    # ------------------------------------------------------------------ collecting
    def add(self, option: str, expected: str, found: object) -> None:
        """One problem with an option."""
        self.problems.append(Problem(option, expected, str(found)))

    def absorb(self, exc: ScenarioError, rename: dict[str, str] | None = None, prefix: str = "") -> None:
        """The problems of a ScenarioError, paths renamed to the options that caused them."""
        rename = rename or {}
        for p in exc.problems:
            path = rename.get(p.path, next((o for f, o in rename.items() if p.path.startswith(f + ".")), None))
            self.problems.append(Problem(path or f"{prefix}{p.path}", p.expected, p.found))

    def scenario(self, text) -> object | None:
        """Load the scenario (None when it is invalid; its problems are kept)."""
        from postcapture.config import load_scenario

        try:
            return load_scenario(text)
        except ScenarioError as exc:
            self.scenario_error = exc
            return None

    def with_options(self, scenario, args, variant: str = "flexible"):
        """The scenario as the command will run it: the options of :data:`OPTION_FIELDS` and
        ``--panel-segments`` applied, validated by the schema (None when they do not fit)."""
        data = scenario.model_dump()
        given = {}
        for option, (field, attr) in OPTION_FIELDS.items():
            value = getattr(args, attr, None)
            if value is not None:
                section, key = field.split(".")
                data[section][key] = value
                given[field] = option
                # a check across the section (the step against the scenario's sample period): every option in it
                given[section] = f"{given[section]}, {option}" if section in given else option
        from pydantic import ValidationError

        from postcapture.config.loader import problems_from_validation

        try:
            effective = type(scenario).model_validate(data)
        except ValidationError as exc:  # reported as the loader does, paths renamed to the options
            self.absorb(ScenarioError(problems_from_validation(exc)), given)
            return None
        segments = getattr(args, "panel_segments", None)
        if segments is not None and variant != "rigid":
            try:
                effective = effective.with_panel_segments(segments)
            except ScenarioError as exc:
                for p in exc.problems:
                    self.add("--panel-segments", p.expected, p.found)
                return None
        return effective

    # ------------------------------------------------------------------ paths
    def output_file(self, option: str, path) -> None:
        """``path`` must be (or become) a regular file we may write."""
        from postcapture.io import check_output_file

        try:
            check_output_file(path)
        except OutputPathError as exc:
            self.add(option, "a path where a regular file can be written", exc)

    def output_folder(self, option: str, path) -> None:
        """``path`` must be (or become) a folder we may write."""
        from postcapture.io import check_output_folder

        try:
            check_output_folder(path)
        except OutputPathError as exc:
            self.add(option, "a path where a results folder can be written", exc)

    def input_file(self, option: str, path, what: str = "an existing, readable file") -> bool:
        """``path`` must be a readable regular file."""
        text = os.fspath(path) if isinstance(path, (str, os.PathLike)) else ""
        if not text.strip():
            self.add(option, what, "an empty path")
            return False
        try:
            ok = Path(text).is_file() and os.access(text, os.R_OK)
        except (OSError, ValueError):
            ok = False
        if not ok:
            kind = "no such file" if not os.path.lexists(text) else "not a readable regular file"
            self.add(option, what, f"{text} ({kind})")
        return ok

    def fmu(self, option: str, path, mapping=None) -> None:
        """An FMU the filters can run here: readable, co-simulation, a binary for this platform, and a mapping
        that fits its variables (nothing is instantiated)."""
        from postcapture.core.errors import FMIError, MissingExtraError
        from postcapture.fmi import fmu_info

        if not self.input_file(option, path, "an existing FMU file"):
            return
        if mapping is not None and not self.input_file("--map", mapping, "an existing mapping TOML file"):
            return
        try:
            info = fmu_info(path, mapping=mapping)
        except (FMIError, MissingExtraError) as exc:
            self.add(option, "an FMU the filters can run", exc)
            return
        for problem in info["mapping"]["problems"]:
            self.add(option, "an FMU and mapping the filters can run", problem)

    def scheduler(self, option: str, address) -> None:
        """A Dask scheduler must answer at ``address`` (a bounded wait, see :mod:`postcapture.studies.scheduler`)."""
        from postcapture.studies.scheduler import check_scheduler

        try:
            check_scheduler(address)
        except ScenarioError as exc:
            self.absorb(exc, {"--scheduler": option})

    # ------------------------------------------------------------------ verdict
    def paths_checked(self) -> None:
        """Raise now when an output path is already refused: a bad ``--out`` is reported within a fraction of a
        second, before the scenario and the run's plan are loaded (which import the numerical libraries)."""
        if self.problems:
            self.finish()

    def finish(self) -> None:
        """Raise the problems found, if any."""
        if self.scenario_error is not None and not self.problems:
            raise self.scenario_error
        problems = list(self.scenario_error.problems if self.scenario_error is not None else []) + self.problems
        if problems:
            raise InputError(problems, f"postcapture {self.command}")

    @staticmethod
    def resources(estimate) -> None:
        """Refuse work beyond the resource limits (:class:`ResourceLimitError`)."""
        from postcapture.config.limits import check_resources

        check_resources(estimate)


# ---------------------------------------------------------------------------------------- commands
def default_simulate_out(scenario, variant: str) -> str:
    """``results/simulate_<scenario>_<variant>.nc``, the scenario's name made file-safe."""
    from postcapture.io import safe_stem

    return f"results/simulate_{safe_stem(scenario.name)}_{variant}.nc"


def simulate(args) -> None:
    """``postcapture simulate``: scenario, options, output file, resources."""
    from postcapture.config.limits import degrees_of_freedom, estimate_simulation, truth_step_guess

    check = Pass("simulate")
    if args.out is not None:
        check.output_file("--out", args.out)
    check.paths_checked()
    scenario = check.scenario(args.scenario)
    effective = check.with_options(scenario, args, args.variant) if scenario is not None else None
    if scenario is not None and args.out is None:
        check.output_file("--out", default_simulate_out(scenario, args.variant))
    check.finish()
    sim = effective.simulation
    check.resources(estimate_simulation(nv=degrees_of_freedom(effective, args.variant), duration=sim.duration,
                                        step=sim.step or truth_step_guess(sim.sample_period),
                                        sample_period=sim.sample_period,
                                        integrator=sim.integrator))


def truth(args, scenario):
    """The truth a command asked for (``--truth-scenario`` or ``--truth-draw``), or None for the nominal one."""
    from postcapture.config import load_scenario
    from postcapture.dynamics.truth import check_priors, draw_truth, truth_from_scenario

    if getattr(args, "truth_scenario", None):
        return truth_from_scenario(scenario, load_scenario(args.truth_scenario), args.truth_scenario)
    if getattr(args, "truth_draw", None) is not None:
        check_priors(scenario)
        return draw_truth(scenario, args.truth_draw)
    return None


def _truth_options(check: Pass, args, scenario) -> None:
    if getattr(args, "truth_scenario", None) is not None:
        if not check.input_file("--truth-scenario", args.truth_scenario, "an existing scenario TOML file"):
            return
    try:
        truth(args, scenario)
    except ScenarioError as exc:
        option = "--truth-scenario" if getattr(args, "truth_scenario", None) else "--truth-draw"
        check.absorb(exc, prefix=f"{option}: ")


def run(args) -> None:
    """``postcapture run``: scenario, every setting of the run (:func:`plan_run`), truth, FMU, output, resources."""
    check = Pass("run")
    check.output_folder("--out", args.out)
    check.paths_checked()
    from postcapture.config.limits import estimate_run
    from postcapture.studies.cases import default_cases
    from postcapture.studies.setup import plan_run

    scenario = check.scenario(args.scenario)
    plant = args.plant
    if plant.startswith("fmu:") and len(plant) > 4:
        check.fmu("--plant", plant[4:], args.map)
    else:
        if plant != "native":
            check.add("--plant", "native or fmu:FILE.fmu", repr(plant))
            plant = "native"
        if args.map is not None:
            check.add("--map", "a mapping only with --plant fmu:FILE.fmu", args.map)
    cases = args.cases or default_cases(plant)[0]
    if scenario is not None:
        try:
            plan_run(scenario, profile=args.profile, duration=args.duration, cases=tuple(cases),
                     initial_mass_error=args.initial_mass_error, seed=args.seed, plant=plant, mapping=args.map)
        except ScenarioError as exc:
            check.absorb(exc, {k: v for k, v in PLAN_FIELDS.items()
                               if getattr(args, v[2:].replace("-", "_"), None) is not None})
        _truth_options(check, args, scenario)
    check.finish()
    check.resources(estimate_run(scenario, duration=args.duration, n_cases=len(cases) + (not args.no_crlb),
                                 workers=min(args.workers, len(cases))))


def campaign(args) -> None:
    """``postcapture campaign``: scenario, options, truth, output folder, resources."""
    from postcapture.config.limits import estimate_run

    check = Pass("campaign")
    check.output_folder("--out", args.out)
    check.paths_checked()
    scenario = check.scenario(args.scenario)
    if args.dispersed and args.truth_scenario:
        check.add("--truth-scenario", "no fixed truth with --dispersed (each run draws its own)", args.truth_scenario)
    elif scenario is not None:
        _truth_options(check, args, scenario)
    if scenario is not None:
        check.with_options(scenario, args)
    if args.scheduler is not None:
        check.scheduler("--scheduler", args.scheduler)
    check.finish()
    check.resources(estimate_run(scenario, duration=args.duration, n_cases=len(args.cases) + (not args.no_crlb),
                                 runs=args.runs, workers=max(1, args.workers)))


def modes(args) -> None:
    """``postcapture modes``: scenario, panel segments, model size."""
    from postcapture.config.limits import degrees_of_freedom, estimate_model

    check = Pass("modes")
    scenario = check.scenario(args.scenario)
    effective = check.with_options(scenario, args, args.variant) if scenario is not None else None
    check.finish()
    check.resources(estimate_model(degrees_of_freedom(effective, args.variant)))


def fmu_export(args) -> None:
    """``postcapture fmu export``: scenario, options, the FMU and mapping files, model size."""
    from postcapture.config.limits import degrees_of_freedom, estimate_model
    from postcapture.fmi.mapping import mapping_sidecar

    check = Pass("fmu export")
    check.output_file("--output", args.output)
    if getattr(args, "ssp", False):
        if not getattr(args, "estimator", None):
            check.add("--estimator", "a case (joint or dual) with --ssp: the archive holds the plant and its estimator",
                      "none")
        if args.fmi != 2:
            check.add("--fmi", "2 with --ssp (OMSimulator, the SSP master, reads FMI 2.0 FMUs)", args.fmi)
        if not str(args.output).lower().endswith(".ssp"):
            check.add("--output", "a FILE.ssp with --ssp (OMSimulator recognises an archive by that suffix)",
                      args.output)
    elif str(args.output).strip():
        check.output_file("--output (its mapping file)", mapping_sidecar(args.output))
    check.paths_checked()
    scenario = check.scenario(args.scenario)
    effective = check.with_options(scenario, args, args.variant) if scenario is not None else None
    check.finish()
    check.resources(estimate_model(degrees_of_freedom(effective, args.variant)))


def fmu_info(args) -> None:
    """``postcapture fmu info``: the FMU and mapping files exist."""
    check = Pass("fmu info")
    check.input_file("FILE.fmu", args.fmu, "an existing FMU file")
    if args.map is not None:
        check.input_file("--map", args.map, "an existing mapping TOML file")
    check.finish()


def panel_calibrate(args) -> None:
    """``postcapture panel calibrate``: panel and reference files, output folder."""
    from postcapture.panels.builtin import BUILTIN_PANELS

    check = Pass("panel calibrate")
    if args.panel not in BUILTIN_PANELS:
        check.input_file("--panel", args.panel, "envisat, chaser or an existing TOML file")
    if args.reference != "fem":
        check.input_file("--reference", args.reference, "fem or an existing OP2 file")
    if args.out is not None:
        check.output_folder("--out", args.out)
    check.finish()


def bench(args) -> None:
    """``postcapture bench``: the scenario."""
    check = Pass("bench")
    check.scenario(args.scenario)
    check.finish()
