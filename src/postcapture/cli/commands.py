"""The commands behind ``postcapture``: each parses nothing, calls one library function and prints.

Results go to stdout, within 80 columns; progress and notes go to stderr (see
:mod:`postcapture.cli.progress`).
"""

from __future__ import annotations

import json
import sys
import textwrap

from postcapture.cli import checks
from postcapture.cli.progress import MAX_COLUMNS, ProgressDisplay
from postcapture.core.errors import Problem, ScenarioError

__all__ = [
    "cmd_simulate",
    "cmd_run",
    "cmd_campaign",
    "cmd_fmu_export",
    "cmd_fmu_info",
    "cmd_modes",
    "cmd_bench",
    "cmd_panel_calibrate",
    "cmd_scenario_show",
    "cmd_scenario_new",
    "cmd_scenario_validate",
    "cmd_scenario_reference",
]


def _display(args, command: str) -> ProgressDisplay:
    """The progress display of a command: bars on a terminal (or ``--progress``), none with ``--json``."""
    mode = getattr(args, "progress", "auto")
    if getattr(args, "json", False) and mode == "auto":
        mode = "off"  # a JSON consumer is a program; it asked for --progress if it wants bars
    return ProgressDisplay(command, mode=mode, verbose=bool(getattr(args, "verbose", False)))


def _print_json(obj) -> None:
    from postcapture.io import json_text

    print(json_text(obj))


def _echo(text: str, *, file=None) -> None:
    """Print text with every line longer than 80 columns wrapped (continuations indented)."""
    for line in text.splitlines() or [""]:
        if len(line) <= MAX_COLUMNS:
            print(line, file=file)
            continue
        indent = " " * (len(line) - len(line.lstrip()))
        for part in textwrap.wrap(line, width=MAX_COLUMNS, subsequent_indent=indent + "  ",
                                  break_on_hyphens=False, break_long_words=True):
            print(part, file=file)


def _note(text: str) -> None:
    """A note on stderr, on its own lines."""
    _echo(f"note: {text}", file=sys.stderr)


def _plant_core(shown) -> None:
    """Load the compiled plant core before the work, saying so: on first use it is compiled (5-10 s)."""
    from postcapture.dynamics.compiled import compile_seconds, load_library

    shown.phase("plant core (compiled on first use, 5-10 s)")
    load_library()
    if compile_seconds() > 0:
        _note(f"the plant core was compiled in {compile_seconds():.1f} s (first use of this version); it is "
              "cached from now on")


def _written(folder, names) -> str:
    return f"written to {folder}/: {', '.join(sorted(names))}"


def cmd_simulate(args) -> int:
    checks.simulate(args)  # everything given, checked before any work
    from postcapture.config import load_scenario
    from postcapture.dynamics.simulate import drift_metrics, simulate
    from postcapture.io.provenance import provenance

    scenario = load_scenario(args.scenario)
    out = args.out or checks.default_simulate_out(scenario, args.variant)
    with _display(args, "simulate") as shown:
        _plant_core(shown)
        shown.phase(f"{scenario.name}, {args.variant} model")
        traj = simulate(
            scenario,
            variant=args.variant,
            duration=args.duration,
            panel_segments=args.panel_segments,
            damping=not args.undamped,
            excitation=not args.free,
            integrator=args.integrator,
            step=args.step,
            progress=shown.fraction_callback("truth simulation"),
        )
        shown.phase("writing the NetCDF file")
        traj.to_netcdf(out, provenance=provenance(scenario))
    wall = traj.attrs["wall_s"]
    duration = float(traj.t[-1] - traj.t[0])
    summary = {
        "scenario": scenario.name,
        "variant": args.variant,
        "duration_s": duration,
        "wall_s": wall,
        "real_time_factor": duration / wall if wall > 0 else float("inf"),
        "n_dof": int(traj.attrs["nv"]),
        "panel_segments": traj.attrs["panel_segments"],
        "integrator": traj.attrs["integrator"],
        "step_s": traj.attrs["step_s"],
        **drift_metrics(traj),
        "out": str(out),
    }
    if args.json:
        _print_json(summary)
    else:
        _echo(f"simulated {duration:g} s of '{scenario.name}' ({args.variant}, {summary['n_dof']} DoF, "
              f"{summary['integrator']} h = {summary['step_s']:g} s) in {wall:.2f} s: "
              f"{summary['real_time_factor']:.1f}x real time")
        _echo(f"energy balance drift {summary['energy_drift_rel']:.2e}, "
              f"angular momentum balance drift {summary['angular_momentum_drift_rel']:.2e}")
        _echo(f"trajectory written to {out}")
    return 0


def _fmu_cases(cases):
    """The cases an FMU plant runs, and a note when some default cases are left out."""
    from postcapture.studies.cases import default_cases

    if cases is not None:
        return cases, None
    kept, skipped = default_cases("fmu")
    note = None
    if skipped:
        note = (f"--plant fmu: runs every case on the FMU's one plant, so the cases of the flexible model run "
                f"({', '.join(kept)}); skipped: {', '.join(skipped)}. For the stiff ones, export a stiff "
                "plant (postcapture fmu export --variant stiff) and pass --cases.")
    return kept, note


def cmd_run(args) -> int:
    checks.run(args)  # everything given, checked before any work
    from postcapture.studies.cases import DEFAULT_CASES
    from postcapture.studies.main_job import run_main_job
    from postcapture.studies.results import run_summary, write_results
    from postcapture.config import load_scenario
    from postcapture.report.table import results_table

    scenario = load_scenario(args.scenario)
    truth = checks.truth(args, scenario)
    plant = args.plant
    cases = args.cases
    if plant != "native":
        if not plant.startswith("fmu:") or not plant[4:]:
            raise ScenarioError([Problem("--plant", "native or fmu:FILE.fmu", repr(plant))])
        cases, note = _fmu_cases(cases)
        if note:
            _note(note)
    cases = cases or DEFAULT_CASES
    with _display(args, "run") as shown:
        _plant_core(shown)
        shown.expect(["truth simulation", *([] if args.no_crlb else ["crlb"]), *cases])
        shown.phase("truth simulation and sensors")
        jobs = len(cases) + (0 if args.no_crlb else 1)  # the Cramer-Rao bound is one more job
        processes = 1 if args.workers == 1 or jobs == 1 else min(args.workers, jobs)
        filters = f"filters: {len(cases)} cases in {processes} process{'es' if processes > 1 else ''}"

        def progress(task: str, fraction: float) -> None:
            if task != "truth simulation" and shown.current_phase != filters:
                shown.phase(filters)
            shown.task(task, fraction)

        result = run_main_job(
            scenario,
            truth=truth,
            profile=args.profile,
            duration=args.duration,
            cases=cases,
            plant=plant,
            mapping=args.map,
            initial_mass_error=args.initial_mass_error,
            seed=args.seed,
            workers=args.workers,
            crlb=not args.no_crlb,
            progress=progress,
        )
        shown.phase("writing results" + ("" if args.no_plots else " and figures"))
        paths = write_results(result, args.out, figures=not args.no_plots, fmt=args.format, dpi=args.dpi)
    summary = run_summary(result)
    if args.json:
        _print_json(summary)
    else:
        print(results_table(summary))
        print()
        _echo(_written(args.out, (p.name for p in paths.values())))
    return 0


def cmd_campaign(args) -> int:
    checks.campaign(args)  # everything given, checked before any work
    from postcapture.studies.montecarlo import run_campaign
    from postcapture.studies.results import write_campaign
    from postcapture.config import load_scenario
    from postcapture.io.provenance import provenance
    from postcapture.report.campaign import campaign_table

    scenario = load_scenario(args.scenario)
    if args.dispersed and args.truth_scenario:
        raise ScenarioError([Problem("--truth-scenario", "no fixed truth with --dispersed (each run draws its own)",
                                     args.truth_scenario)])
    truth = checks.truth(args, scenario)
    with _display(args, "campaign") as shown:
        _plant_core(shown)
        shown.phase(f"{args.runs} runs")

        result = run_campaign(scenario, runs=args.runs, dispersed=args.dispersed, truth=truth, profile=args.profile,
                              cases=args.cases, duration=args.duration, initial_mass_error=args.initial_mass_error,
                              scheduler=args.scheduler, workers=args.workers, out=args.out, fresh=args.fresh,
                              crlb=not args.no_crlb, progress=shown.task)
        shown.phase("writing results" + ("" if args.no_plots else " and figures"))
        paths = write_campaign(result, args.out, figures=not args.no_plots, fmt=args.format, dpi=args.dpi)
    summary = {**result.summary(), "provenance": provenance(result.scenario)}
    if args.json:
        _print_json(summary)
    else:
        print(campaign_table(summary))
        print(f"results written to {args.out}/:")
        print(textwrap.fill(", ".join(sorted(p.name for p in paths.values())), 80, initial_indent="  ",
                            subsequent_indent="  "))
    return 0


def cmd_fmu_export(args) -> int:
    checks.fmu_export(args)  # everything given, checked before any work
    from postcapture.config import load_scenario
    from postcapture.fmi import export_fmu

    scenario = load_scenario(args.scenario)
    if getattr(args, "ssp", False):
        return _export_ssp(args, scenario)
    if getattr(args, "estimator", None):
        return _export_estimator(args, scenario)
    with _display(args, "fmu export") as shown:
        report = export_fmu(scenario, args.output, variant=args.variant, fmi_version=args.fmi,
                            directional_derivatives=not args.no_directional, step_jacobian=not args.no_step_jacobian,
                            panel_segments=args.panel_segments, progress=lambda msg, *rest: shown.phase(msg))
    info = {
        "fmu": str(report.path), "mapping": str(report.mapping_path), "fmi_version": report.fmi_version,
        "variant": report.variant, "integrator": report.integrator, "step_s": report.step,
        "n_states": report.n_states, "n_variables": report.n_variables, "wall_s": report.seconds,
        "codegen_s": report.seconds_codegen, "compile_s": report.seconds_compile,
        "directional_derivatives": report.directional_derivatives, "step_jacobian": report.step_jacobian,
    }
    if args.json:
        _print_json(info)
    else:
        _echo(f"exported {info['fmu']} in {info['wall_s']:.1f} s: FMI {info['fmi_version']} co-simulation, "
              f"{info['variant']} model, {info['n_states']} states, {info['n_variables']} variables")
        _echo(f"its variable mapping: {info['mapping']}")
    return 0


def _export_estimator(args, scenario) -> int:
    from postcapture.studies.estimator_fmu import export_estimator_fmu

    with _display(args, "fmu export --estimator") as shown:
        report = export_estimator_fmu(scenario, args.output, case=args.estimator, profile=args.profile,
                                      fmi_version=args.fmi, progress=lambda msg, *rest: shown.phase(msg))
    info = {"fmu": str(report.path), "fmi_version": report.fmi_version, "case": report.case,
            "profile": report.profile, "period_s": report.period, "n_variables": len(report.variables)}
    if args.json:
        _print_json(info)
    else:
        _echo(f"exported {info['fmu']}: FMI {report.fmi_version} co-simulation, the {report.case} estimator "
              f"({report.profile} profile), one doStep per {report.period:g} s filter cycle, "
              f"{info['n_variables']} variables")
    return 0


def _export_ssp(args, scenario) -> int:
    from postcapture.studies.estimator_ssp import export_estimator_ssp

    with _display(args, "fmu export --ssp") as shown:
        report = export_estimator_ssp(scenario, args.output, case=args.estimator, profile=args.profile,
                                      variant=args.variant, panel_segments=args.panel_segments,
                                      directional_derivatives=not args.no_directional,
                                      step_jacobian=not args.no_step_jacobian,
                                      progress=lambda msg, *rest: shown.phase(msg))
    info = {"ssp": str(report.path), "fmi_version": "2.0", "case": report.case, "profile": report.profile,
            "step_s": report.period, "n_cycles": report.n_cycles, "stop_time_s": report.stop_time,
            "n_connections": len(report.connections), "plant_lead_s": report.period,
            "omsimulator": f"OMSimulator --stopTime={report.stop_time!r} {report.path}"}
    if args.json:
        _print_json(info)
    else:
        _echo(f"exported {info['ssp']}: SSP 1.0, the plant and the {report.case} estimator ({report.profile} "
              f"profile) as FMI 2.0 co-simulation FMUs, {info['n_connections']} connections, one "
              f"{report.period:g} s step per filter cycle; the plant runs one step ahead of the master, so that "
              f"OMSimulator's (Jacobi) hands each cycle the sensors of that cycle")
        _echo(f"run it over {report.n_cycles} cycles with: {info['omsimulator']}")
    return 0


def cmd_fmu_info(args) -> int:
    checks.fmu_info(args)  # everything given, checked before any work
    from postcapture.fmi import fmu_info, format_fmu_info

    info = fmu_info(args.fmu, mapping=args.map)
    if args.json:
        _print_json(info)
    else:
        _echo(format_fmu_info(info))
    return 0


def cmd_modes(args) -> int:
    checks.modes(args)  # everything given, checked before any work
    from postcapture.config import load_scenario
    from postcapture.dynamics.build import build_system
    from postcapture.dynamics.modes import structural_modes

    scenario = load_scenario(args.scenario)
    system = build_system(scenario, args.variant, panel_segments=args.panel_segments)
    modes = structural_modes(system)[: args.count]
    rows = [
        {
            "mode": i + 1,
            "frequency_hz": m.frequency_hz,
            "damping_ratio": m.damping_ratio,
            "dominant": m.dominant,
            "strain_energy_share": {k: v for k, v in m.energy_share.items() if v >= 0.01},
        }
        for i, m in enumerate(modes)
    ]
    if args.json:
        _print_json({"scenario": scenario.name, "variant": args.variant, "n_dof": system.nv, "modes": rows})
        return 0
    _echo(f"elastic modes of '{scenario.name}' ({args.variant}, {system.nv} DoF) at rest; "
          "share = strain energy held by each group")
    print(f"{'#':>3} {'f (Hz)':>10} {'zeta':>7}  what moves")
    lead = " " * 24
    for r in rows:
        share = ", ".join(f"{k} {v:.0%}" for k, v in sorted(r["strain_energy_share"].items(), key=lambda kv: -kv[1]))
        first = f"{r['mode']:>3} {r['frequency_hz']:>10.4f} {r['damping_ratio']:>7.4f}  "
        lines = textwrap.wrap(share, width=MAX_COLUMNS - len(first), break_on_hyphens=False) or [""]
        print(first + lines[0])
        for more in lines[1:]:
            print(lead + more)
    return 0


def cmd_bench(args) -> int:
    checks.bench(args)  # everything given, checked before any work
    if args.accuracy:
        return cmd_accuracy(args)
    from postcapture.studies.bench import run_benchmark

    with _display(args, "bench") as shown:
        result = run_benchmark(args.scenario, duration=args.duration, progress=shown.phase,
                               campaign=getattr(args, "campaign", False))
    if args.json:
        _print_json(result)
        return 0
    _echo(f"truth, {result['integrator']}, attitude tolerance {result['tolerance_rad']:.3g} rad, "
          f"{result['duration_s']:g} s (CPU time, step choice included):")
    for n in (5, 50, 200):
        print(f"  N = {n:>3} ({result[f'n_dof_n{n}']} DoF), h = {result[f'step_s_n{n}']:g} s: "
              f"{result[f'rtf_n{n}']:.0f}x real time")
    print(f"  N =   5 at 1 arcsec: {result['rtf_n5_1arcsec']:.0f}x real time")
    print(f"  prediction with every Jacobian: {result['predict_ms_n5']:.3f} ms (N = 5), "
          f"{result['predict_ms_n50']:.2f} ms (N = 50)")
    print(f"  core compile {result['compile_s']:.1f} s; main job (warm) {result.get('main_job_s', float('nan')):.1f} s")
    m = result["machine"]
    _echo(f"  machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}, {m['compiler']}")
    return 0


def cmd_accuracy(args) -> int:
    from postcapture.studies.accuracy import accuracy_table, integrator_accuracy

    with _display(args, "bench --accuracy") as shown:
        result = integrator_accuracy(args.scenario, duration=args.duration, task_progress=shown.task)
    if args.json:
        _print_json(result)
        return 0
    print(accuracy_table(result))  # the Markdown table BENCHMARKS.md quotes, with the machine
    return 0


def cmd_panel_calibrate(args) -> int:
    checks.panel_calibrate(args)  # everything given, checked before any work
    from postcapture.panels import calibrate
    from postcapture.report.panels import calibration_figures

    with _display(args, "panel calibrate") as shown:

        def progress(done, total, message):
            shown.say(f"  [{done}/{total}] {message}")
            shown.task("calibration", done / total)

        shown.phase(f"panel {args.panel}, {args.segments} segments")
        shown.task("calibration", 0.0)
        result = calibrate(args.panel, segments=args.segments, weights=args.weights, reference=args.reference,
                           force_reference=args.force_reference, progress=progress)
        if args.out:
            shown.phase("writing tables, JSON, TOML and figures")
            result.write(args.out, figures=calibration_figures)
    if args.json:
        print(result.to_json())
    else:
        _echo(result.tables())
        if args.out:
            _echo(f"tables, JSON, TOML fragment and figures written to {args.out}")
    return 0


def cmd_scenario_show(args) -> int:
    """``postcapture scenario show NAME|FILE``: a built-in scenario's text; a file's validated content as TOML."""
    from postcapture.config import builtin_scenarios, load_scenario
    from postcapture.config.tooling import builtin_text

    if args.name in builtin_scenarios():
        print(builtin_text(args.name), end="")
        return 0
    import tomli_w

    from postcapture.io import plain

    scenario = load_scenario(args.name)
    print(tomli_w.dumps(plain(scenario.model_dump(exclude_none=True))), end="")
    return 0


def cmd_scenario_new(args) -> int:
    """``postcapture scenario new --like NAME -o FILE``: a copy of a built-in scenario to edit."""
    from pathlib import Path

    from postcapture.config.tooling import new_scenario_text
    from postcapture.io import check_output_file, write_atomic

    check = checks.Pass("scenario new")
    check.output_file("--output", args.output)
    if Path(args.output).exists():
        check.add("--output", "a new file (scenario new never overwrites one)", f"{args.output} (exists)")
    check.finish()
    text = new_scenario_text(args.like, Path(args.output).stem)
    check_output_file(args.output)
    write_atomic(args.output, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
    _echo(f"written {args.output}: a copy of '{args.like}' named '{Path(args.output).stem}'; edit it, then check it "
          f"with `postcapture scenario validate {args.output}`")
    return 0


def cmd_scenario_validate(args) -> int:
    """``postcapture scenario validate FILE``: every problem with its path; the exit status is their number."""
    from postcapture.config.tooling import check_scenario_file

    scenario, problems = check_scenario_file(args.file)
    if args.json:
        _print_json({"file": args.file, "valid": scenario is not None,
                     "problems": [{"path": p.path, "expected": p.expected, "found": p.found} for p in problems]})
    elif scenario is not None:
        panels = len(scenario.panels())
        _echo(f"{args.file}: valid scenario '{scenario.name}': {scenario.n_arm} arm joints, {panels} panels, "
              f"{'a target of ' + format(scenario.target.mass, 'g') + ' kg' if scenario.target else 'no target'}, "
              f"{scenario.simulation.duration:g} s")
    else:
        _echo(f"{args.file}: {len(problems)} problem{'s' if len(problems) != 1 else ''}", file=sys.stderr)
        for p in problems:
            _echo(f"  - {p}", file=sys.stderr)
    return min(len(problems), 100)


def cmd_scenario_reference(args) -> int:
    """``postcapture scenario reference``: the field reference page (Markdown)."""
    from postcapture.config.reference import reference_markdown

    print(reference_markdown(), end="")
    return 0
