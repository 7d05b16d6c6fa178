"""The ``postcapture`` command line: parse, call one library function, print.

Exit status: 0 success; 1 a user error (bad scenario, missing file, bad option, a resource limit): one
message on stderr, no traceback; 2 an internal error (a bug): a short report and a hint to run again
with ``-v``, which prints the traceback; 130 interrupted by Ctrl-C (SIGINT), 143 stopped by SIGTERM: one
line. Every command checks everything it was given before any work starts (:mod:`postcapture.cli.checks`).
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import threading
import traceback

from postcapture.cli import commands

__all__ = ["main", "build_parser"]

EXAMPLES = """examples:
  postcapture run --out results                      # the main job on the embedded Envisat scenario
  postcapture run --profile realistic --json
  postcapture simulate --duration 60 --json
  postcapture simulate --scenario my_scenario.toml --variant stiff --out run.nc
  postcapture modes --count 12
  postcapture panel calibrate --panel envisat --weights 1,10,0.1 --out results/panel
  postcapture fmu export -o envisat.fmu && postcapture fmu info envisat.fmu
  postcapture run --plant fmu:envisat.fmu
  postcapture run --truth-draw 7 --profile realistic     # the truth drawn from the scenario's priors
  postcapture campaign --runs 50 --dispersed --out results/campaign
  postcapture bench --json
"""


def _single_threaded() -> None:
    """Small matrices are faster on one BLAS thread; this must run before numpy is imported."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")


def _cases(text: str) -> tuple[str, ...]:
    from postcapture.studies.cases import CASES

    names = tuple(x.strip() for x in text.split(",") if x.strip())
    bad = [n for n in names if n not in CASES]
    if not names or bad:
        raise argparse.ArgumentTypeError(f"expected case names among {', '.join(CASES)}, found {text!r}")
    return names


def _weights(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated positive numbers, found {text!r}") from None
    if not values or any(not v > 0 or v == float("inf") for v in values):
        raise argparse.ArgumentTypeError(f"expected comma-separated positive numbers, found {text!r}")
    return values


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


def _nonnegative_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, found {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, found {text!r}")
    return value


def _seed(text: str) -> int:
    from postcapture.config.types import SEED_LIMIT

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a seed, an integer in [0, 2**63), found {text!r}") from None
    if not 0 <= value < SEED_LIMIT:
        raise argparse.ArgumentTypeError(f"expected a seed, an integer in [0, 2**63), found {text!r}")
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
    parser.add_argument("-v", "--verbose", action="store_true",
                        help="log each phase, each task's start, every 10 %% of it and its end (stderr)")
    parser.add_argument("--progress", dest="progress", action="store_const", const="on", default="auto",
                        help="progress bars on stderr even when it is not a terminal")
    parser.add_argument("--no-progress", dest="progress", action="store_const", const="off",
                        help="no progress bars, even on a terminal")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def scenario_args(p):
        p.add_argument("--scenario", default="envisat", help="built-in name or TOML path (default: envisat)")
        p.add_argument("--variant", default="flexible", choices=["flexible", "stiff", "rigid"])
        p.add_argument("--panel-segments", type=_positive_int, default=None, metavar="N",
                       help="cut every panel into N segments (stiffnesses derived from EI(s))")

    p = sub.add_parser("run", help="the main job: truth, sensors, the recommended dual and joint estimators and the reference's four")
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
    p.add_argument("--seed", type=_seed, default=None, help="sensor-noise seed (default: scenario)")
    truth = p.add_mutually_exclusive_group()
    truth.add_argument("--truth-scenario", default=None, metavar="PATH",
                       help="simulate the truth from this scenario (same arm and panels); the filters keep --scenario")
    truth.add_argument("--truth-draw", type=_seed, default=None, metavar="SEED",
                       help="simulate a truth drawn from the scenario's [uncertainty] priors")
    p.add_argument("--workers", type=_positive_int, default=2, help="processes for the cases (default 2)")
    p.add_argument("--no-crlb", action="store_true", help="skip the Cramer-Rao bound")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.add_argument("--out", default="results", metavar="DIR", help="results folder (default: results)")
    p.add_argument("--json", action="store_true", help="print the JSON summary on stdout")
    p.set_defaults(func=commands.cmd_run)

    p = sub.add_parser("campaign", help="Monte Carlo over noise seeds and drawn truths, on Dask")
    p.add_argument("--scenario", default="envisat", help="built-in name or TOML path (default: envisat)")
    p.add_argument("--runs", type=_positive_int, required=True, metavar="N", help="number of runs")
    p.add_argument("--dispersed", action="store_true", help="draw each run's truth from the scenario's [uncertainty]")
    p.add_argument("--truth-scenario", default=None, metavar="PATH",
                   help="one truth for every run from this scenario (not with --dispersed)")
    p.add_argument("--profile", choices=["reference", "realistic"], default="realistic",
                   help="sensor profile and tuning (default: realistic)")
    p.add_argument("--cases", type=_cases, default=("dual", "joint"), metavar="A,B,...",
                   help="cases to run (default: the recommended dual,joint)")
    p.add_argument("--duration", type=_positive_float, default=None, metavar="S", help="seconds (default: scenario)")
    p.add_argument("--initial-mass-error", type=float, default=None, metavar="KG",
                   help="added to the nominal mass to start the filters (default: scenario)")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="a running Dask scheduler (default: a local cluster)")
    p.add_argument("--workers", type=_nonnegative_int, default=2, metavar="K",
                   help="worker processes of the local cluster; 0 runs in this process (default 2)")
    p.add_argument("--out", required=True, metavar="DIR", help="results folder; a campaign started again resumes there")
    p.add_argument("--fresh", action="store_true", help="discard runs saved in DIR instead of resuming")
    p.add_argument("--no-crlb", action="store_true", help="skip the Cramer-Rao bound")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.add_argument("--json", action="store_true", help="print the JSON summary on stdout")
    p.set_defaults(func=commands.cmd_campaign)

    p = sub.add_parser("simulate", help="truth simulation to a NetCDF file")
    scenario_args(p)
    p.add_argument("--duration", type=_positive_float, default=None, metavar="S", help="seconds (default: scenario)")
    p.add_argument("--integrator", choices=["sdirk3", "sdirk2", "rk4"], default=None)
    p.add_argument("--step", type=_positive_float, default=None, metavar="H", help="integrator step (s)")
    p.add_argument("--undamped", action="store_true", help="set every damper to zero")
    p.add_argument("--free", action="store_true", help="no excitation inputs")
    p.add_argument("--out", default=None, metavar="FILE", help="NetCDF output (default: results/simulate_<scenario>_<variant>.nc)")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.set_defaults(func=commands.cmd_simulate)

    p = sub.add_parser("modes", help="natural frequencies and what moves in each mode")
    scenario_args(p)
    p.add_argument("--count", type=_positive_int, default=20, help="number of modes to list (default 20)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=commands.cmd_modes)

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
    c.add_argument("--force-reference", action="store_true",
                   help="use an OP2 reference even beyond the tolerance of the project's own FEM (mass, frequencies)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=commands.cmd_panel_calibrate)

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
    c.set_defaults(func=commands.cmd_fmu_export)
    c = fmu_sub.add_parser("info", help="variables, capabilities and what a filter mapping needs")
    c.add_argument("fmu", metavar="FILE.fmu")
    c.add_argument("--map", default=None, metavar="MAP.toml")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=commands.cmd_fmu_info)

    p = sub.add_parser("bench", help="speed benchmark (real-time factors, step Jacobian, build time)")
    p.add_argument("--scenario", default="envisat")
    p.add_argument("--duration", type=_positive_float, default=300.0, metavar="S", help="simulated seconds per case")
    p.add_argument("--accuracy", action="store_true",
                   help="instead: integrator accuracy against RK4 at 0.25 ms (40 s forced and free; minutes)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=commands.cmd_bench)
    return parser


class Terminated(BaseException):
    """SIGTERM, raised in the main thread so that every ``finally`` and ``with`` cleans up."""


def _on_sigterm(signum, frame):
    raise Terminated()


def _report(exc: BaseException, verbose: bool) -> int:
    """One message for an exception that reached the top level; the exit status."""
    from postcapture.core.errors import PostcaptureError, WorkerError

    if isinstance(exc, WorkerError):
        print(f"postcapture: internal error: {exc}", file=sys.stderr)
        if verbose:
            print(exc.traceback, file=sys.stderr, end="")
        else:
            print("postcapture: this is a bug; run again with -v for the worker's traceback, and report it",
                  file=sys.stderr)
        return 2
    if isinstance(exc, PostcaptureError):
        print(f"postcapture: error: {exc}", file=sys.stderr)
        return 1
    if isinstance(exc, OSError):
        text = f"{exc.filename}: {exc.strerror}" if exc.filename and exc.strerror else (exc.strerror or str(exc))
        print(f"postcapture: error: {text}", file=sys.stderr)
        return 1
    if isinstance(exc, MemoryError):
        print("postcapture: error: out of memory (lower the limit POSTCAPTURE_MAX_MEMORY so that such runs are "
              "refused up front, or make the run smaller)", file=sys.stderr)
        return 1
    where = traceback.extract_tb(exc.__traceback__)[-1] if exc.__traceback__ else None
    at = f" (at {os.path.basename(where.filename)}:{where.lineno})" if where else ""
    print(f"postcapture: internal error: {type(exc).__name__}: {exc}{at}", file=sys.stderr)
    if verbose:
        traceback.print_exception(exc, file=sys.stderr)
    else:
        print("postcapture: this is a bug; run again with -v for the traceback, and report it", file=sys.stderr)
    return 2


def _silence_stdout() -> None:
    # Python flushes stdout again at exit, which would raise a second time into the closed pipe
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError):
        pass


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``postcapture`` console script; returns the exit status."""
    _single_threaded()
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("postcapture: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (`postcapture fmu info X | head`): not an error to report
        _silence_stdout()
        return 141
    except Terminated:
        print("postcapture: terminated", file=sys.stderr)
        return 143
    except Exception as exc:  # the top-level handler: one message, never a traceback unless -v
        return _report(exc, args.verbose)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
