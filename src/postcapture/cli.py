"""The ``postcapture`` command line: parse, call one library function, print.

User errors (bad scenario, missing file, bad option) print one message on stderr and exit with 1.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import sys

from postcapture.core.errors import Problem, ScenarioError

__all__ = ["main"]

EXAMPLES = """examples:
  postcapture run --out results                      # the main job on the embedded Envisat scenario
  postcapture run --profile realistic --json
  postcapture simulate --duration 60 --json
  postcapture simulate --scenario my_scenario.toml --variant stiff --out run.nc
  postcapture modes --count 12
  postcapture panel calibrate --panel envisat --weights 1,10,0.1 --out results/panel
  postcapture fmu export -o envisat.fmu && postcapture fmu info envisat.fmu
  postcapture run --plant fmu:envisat.fmu
  postcapture bench --json
"""


def _single_threaded() -> None:
    """Small matrices are faster on one BLAS thread; this must run before numpy is imported."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")


def _progress_bar(desc: str):
    """A tqdm bar on stderr (hidden when stderr is not a terminal) and a fraction callback."""
    from tqdm import tqdm

    bar = tqdm(total=1000, desc=desc, unit="‰", disable=None, file=sys.stderr, leave=False)

    def update(fraction: float) -> None:
        target = int(round(fraction * 1000))
        if target > bar.n:
            bar.update(target - bar.n)

    return bar, update


def _print_json(obj) -> None:
    print(json.dumps(obj, indent=2, default=float))


# ---------------------------------------------------------------------------------------- commands
def _cmd_simulate(args) -> int:
    from postcapture.config import load_scenario
    from postcapture.dynamics.simulate import drift_metrics, simulate

    scenario = load_scenario(args.scenario)
    bar, update = _progress_bar("simulate")
    with bar:
        traj = simulate(
            scenario,
            variant=args.variant,
            duration=args.duration,
            panel_segments=args.panel_segments,
            damping=not args.undamped,
            excitation=not args.free,
            integrator=args.integrator,
            step=args.step,
            progress=update,
        )
    out = args.out or f"results/simulate_{scenario.name}_{args.variant}.nc"
    traj.to_netcdf(out)
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
        print(f"simulated {duration:g} s of '{scenario.name}' ({args.variant}, {summary['n_dof']} DoF, "
              f"{summary['integrator']} h = {summary['step_s']:g} s) in {wall:.2f} s: "
              f"{summary['real_time_factor']:.1f}x real time")
        print(f"energy balance drift {summary['energy_drift_rel']:.2e}, "
              f"angular momentum balance drift {summary['angular_momentum_drift_rel']:.2e}")
        print(f"trajectory written to {out}")
    return 0


def _cmd_run(args) -> int:
    from postcapture.campaign.main_job import run_main_job
    from postcapture.campaign.results import write_results
    from postcapture.config import load_scenario
    from postcapture.report.estimation import results_table

    scenario = load_scenario(args.scenario)
    plant = args.plant
    cases = args.cases
    if plant != "native":
        if not plant.startswith("fmu:") or not plant[4:]:
            raise ScenarioError([Problem("--plant", "native or fmu:FILE.fmu", repr(plant))])
        if cases is None:  # an FMU is one plant: run the cases meant for the flexible model
            cases = ("ekf_flexible", "mekf_flexible", "joint_flexible")
    bar, update = _progress_bar("run")
    with bar:
        result = run_main_job(
            scenario,
            profile=args.profile,
            duration=args.duration,
            cases=cases or ("ekf_flexible", "ekf_stiff", "mekf_flexible", "mekf_stiff", "joint_flexible"),
            plant=plant,
            mapping=args.map,
            initial_mass_error=args.initial_mass_error,
            seed=args.seed,
            workers=args.workers,
            crlb=not args.no_crlb,
            progress=lambda msg, frac: (bar.set_description(f"run: {msg}"), update(frac)),
        )
    paths = write_results(result, args.out, figures=not args.no_plots)
    summary = result.summary()
    if args.json:
        _print_json(summary)
    else:
        print(results_table(summary))
        print(f"results written to {args.out}/ ({', '.join(sorted(p.name for p in paths.values()))})")
    return 0


def _cmd_fmu_export(args) -> int:
    from postcapture.config import load_scenario
    from postcapture.fmi import export_fmu

    scenario = load_scenario(args.scenario)
    if args.fmi != 2:
        raise ScenarioError([Problem("--fmi", "2 (FMI 3.0 export is not implemented yet)", str(args.fmi))])

    def progress(msg, *rest):
        if not args.json:
            print(f"  ... {msg}", file=sys.stderr)

    report = export_fmu(scenario, args.output, variant=args.variant, fmi_version=args.fmi,
                        directional_derivatives=not args.no_directional, step_jacobian=not args.no_step_jacobian,
                        panel_segments=args.panel_segments, progress=progress)
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
        print(f"exported {info['fmu']} (FMI {info['fmi_version']} co-simulation, {info['variant']}, "
              f"{info['n_states']} states, {info['n_variables']} variables) in {info['wall_s']:.1f} s; "
              f"mapping {info['mapping']}")
    return 0


def _cmd_fmu_info(args) -> int:
    from postcapture.fmi import fmu_info, format_fmu_info

    info = fmu_info(args.fmu, mapping=args.map)
    if args.json:
        _print_json(info)
    else:
        print(format_fmu_info(info))
    return 0


def _cases(text: str) -> tuple[str, ...]:
    from postcapture.campaign.cases import CASES

    names = tuple(x.strip() for x in text.split(",") if x.strip())
    bad = [n for n in names if n not in CASES]
    if not names or bad:
        raise argparse.ArgumentTypeError(f"expected case names among {', '.join(CASES)}, found {text!r}")
    return names


def _cmd_modes(args) -> int:
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
    print(f"elastic modes of '{scenario.name}' ({args.variant}, {system.nv} DoF) at rest; "
          "share = strain energy held by each group")
    print(f"{'#':>3} {'f (Hz)':>10} {'zeta':>7}  what moves")
    for r in rows:
        share = ", ".join(f"{k} {v:.0%}" for k, v in sorted(r["strain_energy_share"].items(), key=lambda kv: -kv[1]))
        print(f"{r['mode']:>3} {r['frequency_hz']:>10.4f} {r['damping_ratio']:>7.4f}  {share}")
    return 0


def _cmd_bench(args) -> int:
    if args.accuracy:
        return _cmd_accuracy(args)
    from postcapture.campaign.bench import run_benchmark

    bar_msgs = []

    def progress(msg: str) -> None:
        bar_msgs.append(msg)
        if not args.json:
            print(f"  ... {msg}", file=sys.stderr)

    result = run_benchmark(args.scenario, duration=args.duration, progress=progress)
    if args.json:
        _print_json(result)
        return 0
    print(f"truth simulation, {result['integrator']} h = {result['step_s']} s, outputs every {result['sample_period_s']} s:")
    for n in (5, 20, 50):
        print(f"  N = {n:>2} panel segments ({result[f'n_dof_n{n}']} DoF): {result[f'rtf_n{n}']:.1f}x real time")
    print(f"  exact step Jacobian at N = 5: {result['step_jacobian_ms_n5']:.2f} ms")
    print(f"  model build at N = 50: {result['build_s_n50'] * 1e3:.1f} ms")
    m = result["machine"]
    print(f"  machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}, Pinocchio {m['pinocchio']}")
    return 0


def _cmd_accuracy(args) -> int:
    from postcapture.campaign.accuracy import integrator_accuracy

    def progress(msg: str) -> None:
        if not args.json:
            print(f"  ... {msg}", file=sys.stderr)

    result = integrator_accuracy(args.scenario, duration=args.duration if args.duration != 60.0 else 40.0, progress=progress)
    if args.json:
        _print_json(result)
        return 0
    print(f"largest deviation from {result['reference']} over {result['duration_s']:g} s")
    for label in ("forced", "free"):
        print(f"  {label}:")
        print(f"    {'method':<18}{'attitude':>12}{'rate':>11}{'tip':>10}{'accel':>10}{'arm ddq':>10}{'wall':>8}")
        for name, r in result[label].items():
            print(f"    {name:<18}{r['attitude_arcsec']:>9.3g} as{r['rate_rad_s']:>11.2e}{r['tip_rel']:>10.2e}"
                  f"{r['accel_rel']:>10.2e}{r['arm_ddq_rel']:>10.2e}{r['wall_s']:>7.1f}s")
    return 0


def _weights(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated positive numbers, found {text!r}") from None
    if not values or any(not v > 0 or v == float("inf") for v in values):
        raise argparse.ArgumentTypeError(f"expected comma-separated positive numbers, found {text!r}")
    return values


def _cmd_panel_calibrate(args) -> int:
    from postcapture.panels import calibrate
    from postcapture.report.panels import calibration_figures

    def progress(done, total, message):
        if not args.json:
            print(f"  [{done}/{total}] {message}", file=sys.stderr)

    result = calibrate(args.panel, segments=args.segments, weights=args.weights, reference=args.reference,
                       progress=progress)
    if args.out:
        result.write(args.out, figures=calibration_figures)
    if args.json:
        print(result.to_json())
    else:
        print(result.tables())
        if args.out:
            print(f"tables, JSON, TOML fragment and figures written to {args.out}")
    return 0


# ---------------------------------------------------------------------------------------- parser
def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive number, found {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive number, found {text!r}")
    return value


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, found {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, found {text!r}")
    return value


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit status 1 (argparse's default is 2)
        self.print_usage(sys.stderr)
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        raise SystemExit(1)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (also used to document the CLI)."""
    from postcapture import __version__

    parser = _Parser(
        prog="postcapture",
        description="Post-capture simulation and estimation: a chaser holding Envisat through a flexible arm.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"postcapture {__version__}")
    parser.add_argument("-v", "--verbose", action="store_true", help="log progress details")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def scenario_args(p):
        p.add_argument("--scenario", default="envisat", help="built-in name or TOML path (default: envisat)")
        p.add_argument("--variant", default="flexible", choices=["flexible", "stiff", "rigid"])
        p.add_argument("--panel-segments", type=_positive_int, default=None, metavar="N",
                       help="cut every panel into N segments (stiffnesses derived from EI(s))")

    p = sub.add_parser("run", help="the main job: truth, sensors, EKF/MEKF dual schemes and the joint EKF")
    p.add_argument("--scenario", default="envisat", help="built-in name or TOML path (default: envisat)")
    p.add_argument("--duration", type=_positive_float, default=None, metavar="S", help="seconds (default: scenario)")
    p.add_argument("--profile", choices=["reference", "realistic"], default="reference",
                   help="sensor profile and tuning (default: reference)")
    p.add_argument("--cases", type=_cases, default=None, metavar="A,B,...",
                   help="cases to run (default: the reference's four dual schemes and the joint EKF)")
    p.add_argument("--plant", default="native", metavar="native|fmu:FILE.fmu",
                   help="the filters' process model: the native Pinocchio model or a co-simulation FMU")
    p.add_argument("--map", default=None, metavar="MAP.toml", help="mapping of the FMU's variables (default: its own)")
    p.add_argument("--initial-mass-error", type=float, default=None, metavar="KG",
                   help="added to the true mass to start the filters (default: scenario, -100 kg)")
    p.add_argument("--seed", type=int, default=None, help="sensor-noise seed (default: scenario)")
    p.add_argument("--workers", type=_positive_int, default=2, help="processes for the cases (default 2)")
    p.add_argument("--no-crlb", action="store_true", help="skip the Cramer-Rao bound")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.add_argument("--out", default="results", metavar="DIR", help="results folder (default: results)")
    p.add_argument("--json", action="store_true", help="print the JSON summary on stdout")
    p.set_defaults(func=_cmd_run)

    p = sub.add_parser("simulate", help="truth simulation to a NetCDF file")
    scenario_args(p)
    p.add_argument("--duration", type=_positive_float, default=None, metavar="S", help="seconds (default: scenario)")
    p.add_argument("--integrator", choices=["sdirk3", "sdirk2", "rk4"], default=None)
    p.add_argument("--step", type=_positive_float, default=None, metavar="H", help="integrator step (s)")
    p.add_argument("--undamped", action="store_true", help="set every damper to zero")
    p.add_argument("--free", action="store_true", help="no excitation inputs")
    p.add_argument("--out", default=None, metavar="FILE", help="NetCDF output (default: results/simulate_<scenario>_<variant>.nc)")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser("modes", help="natural frequencies and what moves in each mode")
    scenario_args(p)
    p.add_argument("--count", type=_positive_int, default=20, help="number of modes to list (default 20)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_modes)

    p = sub.add_parser("panel", help="panel models: calibrate the lumped chain against a plate FEM")
    panel_sub = p.add_subparsers(dest="panel_command", required=True, parser_class=_Parser)
    c = panel_sub.add_parser("calibrate", help="fit the lumped panel stiffnesses to the FEM and validate by a sine sweep")
    c.add_argument("--panel", default="envisat", help="envisat, chaser, or a TOML file with geometry and laminate")
    c.add_argument("--segments", type=_positive_int, default=5, metavar="N", help="rigid segments (default 5)")
    c.add_argument("--weights", type=_weights, default=(1.0, 10.0, 0.1), metavar="W1,W2,...",
                   help="mode-shape weights of the fit, one run each (default 1,10,0.1)")
    c.add_argument("--reference", default="fem", metavar="fem|OP2FILE",
                   help="the built-in plate FEM, or modes read from a Nastran OP2 file")
    c.add_argument("--out", default=None, metavar="DIR", help="write tables, JSON, a TOML fragment and figures here")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=_cmd_panel_calibrate)

    p = sub.add_parser("fmu", help="FMI: export the plant as a co-simulation FMU, inspect an FMU")
    fmu_sub = p.add_subparsers(dest="fmu_command", required=True, parser_class=_Parser)
    c = fmu_sub.add_parser("export", help="build a co-simulation FMU (compiled C) of the scenario's plant")
    c.add_argument("--scenario", default="envisat")
    c.add_argument("--variant", default="flexible", choices=["flexible", "stiff", "rigid"])
    c.add_argument("--fmi", type=int, default=2, choices=[2, 3], help="FMI version (2; 3 is not implemented yet)")
    c.add_argument("--panel-segments", type=_positive_int, default=None, metavar="N")
    c.add_argument("--no-directional", action="store_true", help="without fmi2GetDirectionalDerivative")
    c.add_argument("--no-step-jacobian", action="store_true", help="without the exact step-Jacobian outputs")
    c.add_argument("-o", "--output", required=True, metavar="FILE.fmu")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=_cmd_fmu_export)
    c = fmu_sub.add_parser("info", help="variables, capabilities and what a filter mapping needs")
    c.add_argument("fmu", metavar="FILE.fmu")
    c.add_argument("--map", default=None, metavar="MAP.toml")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=_cmd_fmu_info)

    p = sub.add_parser("bench", help="speed benchmark (real-time factors, step Jacobian, build time)")
    p.add_argument("--scenario", default="envisat")
    p.add_argument("--duration", type=_positive_float, default=60.0, metavar="S", help="simulated seconds per case")
    p.add_argument("--accuracy", action="store_true",
                   help="instead: integrator accuracy against RK4 at 0.25 ms (40 s forced and free; minutes)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=_cmd_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``postcapture`` console script; returns the exit status."""
    _single_threaded()
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    from postcapture.core.errors import PostcaptureError

    try:
        return int(args.func(args) or 0)
    except PostcaptureError as exc:
        print(f"postcapture: error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"postcapture: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("postcapture: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
