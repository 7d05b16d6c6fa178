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
import re
import signal
import sys
import threading
import traceback

from postcapture.cli import commands
from postcapture.config.names import INTEGRATORS, MAX_SEGMENTS, PROFILES, VARIANTS

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


def _integer(low: int, high: int, what: str = "an integer"):
    """An option type: an integer in ``[low, high]`` written in ASCII digits (``int`` would also read other
    scripts' digits and any size)."""

    def parse(text: str) -> int:
        expected = f"{what} in [{low}, {high}]"
        if not re.fullmatch(r"[+-]?[0-9]{1,19}", text.strip(), re.ASCII):
            raise argparse.ArgumentTypeError(f"expected {expected} (ASCII digits), found {text!r}")
        value = int(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"expected {expected}, found {text!r}")
        return value

    parse.__name__ = what  # argparse names the type in its own messages
    return parse


_MAX_RUNS = 1_000_000
_MAX_MODES = 100_000
_MAX_WORKERS = 256  # the same bound as studies.scheduler.MAX_WORKERS, kept here so that parsing imports nothing
_positive_int = _integer(1, 2**31 - 1, "a positive integer")
_segments = _integer(1, MAX_SEGMENTS, "a number of panel segments")


def _seed(text: str) -> int:
    from postcapture.config.types import SEED_LIMIT

    if not re.fullmatch(r"[0-9]{1,19}", text.strip(), re.ASCII) or not 0 <= int(text) < SEED_LIMIT:
        raise argparse.ArgumentTypeError(f"expected a seed, an integer in [0, 2**63) in ASCII digits, found {text!r}")
    return int(text)


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Help whose lists come from the library when help is printed (so that building the parser stays light)."""

    def _get_help_string(self, action):
        text = super()._get_help_string(action)
        if "{default_cases}" in text:
            from postcapture.studies.cases import DEFAULT_CASES

            text = text.replace("{default_cases}", ",".join(DEFAULT_CASES))
        if "{cases}" in text:
            from postcapture.studies.cases import CASES

            text = text.replace("{cases}", ", ".join(CASES))
        return text


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, exit status 1 (argparse's default is 2)
        self.print_usage(sys.stderr)
        print(f"{self.prog}: error: {message}", file=sys.stderr)
        raise SystemExit(1)


def _global_options(parser: argparse.ArgumentParser, *, defaults: bool) -> None:
    """``-v``, ``--progress``, ``--no-progress``: before the subcommand or after it (a subcommand's copy leaves
    the value alone unless given there)."""
    keep = {} if defaults else {"default": argparse.SUPPRESS}
    parser.add_argument("-v", "--verbose", action="store_true", **({"default": False} if defaults else keep),
                        help="log each phase, each task's start, every 10 %% of it and its end (stderr)")
    parser.add_argument("--progress", dest="progress", action="store_const", const="on",
                        **({"default": "auto"} if defaults else keep),
                        help="progress bars on stderr even when it is not a terminal")
    parser.add_argument("--no-progress", dest="progress", action="store_const", const="off", **keep,
                        help="no progress bars, even on a terminal")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (also used to document the CLI)."""
    from postcapture._version import __version__

    parser = _Parser(
        prog="postcapture",
        description="Post-capture simulation and estimation: a chaser holding Envisat through a flexible arm.",
        epilog=EXAMPLES,
        formatter_class=_Formatter,
    )
    parser.add_argument("--version", action="version", version=f"postcapture {__version__}")
    _global_options(parser, defaults=True)
    common = argparse.ArgumentParser(add_help=False)
    _global_options(common, defaults=False)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def command(subparsers, name, **kw):
        return subparsers.add_parser(name, parents=[common], formatter_class=_Formatter, **kw)

    def scenario_args(p):
        p.add_argument("--scenario", default="envisat", help="built-in name or TOML path (default: envisat)")
        p.add_argument("--variant", default="flexible", choices=VARIANTS)
        p.add_argument("--panel-segments", type=_segments, default=None, metavar="N",
                       help="cut every panel into N segments (stiffnesses derived from EI(s))")

    def study_args(p, default_profile, other):
        p.add_argument("--scenario", default="envisat", help="built-in name or TOML path (default: envisat)")
        p.add_argument("--profile", choices=PROFILES, default=default_profile,
                       help=f"sensor profile and tuning (default: {default_profile}; {other})")
        p.add_argument("--duration", type=_positive_float, default=None, metavar="S", help="seconds (default: scenario)")
        p.add_argument("--initial-mass-error", type=float, default=None, metavar="KG",
                       help="added to the nominal target mass to start every filter (default: the scenario's, "
                            "[estimation] initial_mass_error)")
        p.add_argument("--no-crlb", action="store_true", help="skip the Cramer-Rao bound")
        p.add_argument("--no-plots", action="store_true", help="skip the figures and the report's pictures")
        p.add_argument("--format", choices=("png", "pdf", "svg"), default="png", help="figure files (default png)")
        p.add_argument("--dpi", type=_integer(30, 1200, "a resolution"), default=None,
                       help="resolution of PNG figures (default 110)")
        p.add_argument("--json", action="store_true", help="print the JSON summary on stdout")

    p = command(sub, "run", help="the main job: truth, sensors, the recommended dual and joint estimators and the "
                                 "reference's four")
    study_args(p, "reference", "campaign's default is realistic")
    p.add_argument("--cases", type=_cases, default=None, metavar="A,B,...",
                   help="cases to run, among {cases} (default: {default_cases})")
    p.add_argument("--plant", default="native", metavar="native|fmu:FILE.fmu",
                   help="the filters' process model: the native compiled model or a co-simulation FMU")
    p.add_argument("--map", default=None, metavar="MAP.toml", help="mapping of the FMU's variables (default: its own)")
    p.add_argument("--seed", type=_seed, default=None, help="sensor-noise seed (default: scenario)")
    truth = p.add_mutually_exclusive_group()
    truth.add_argument("--truth-scenario", default=None, metavar="PATH",
                       help="simulate the truth from this scenario (same arm and panels); the filters keep --scenario")
    truth.add_argument("--truth-draw", type=_seed, default=None, metavar="SEED",
                       help="simulate a truth drawn from the scenario's [uncertainty] priors")
    p.add_argument("--workers", type=_integer(1, _MAX_WORKERS, "a number of processes"), default=2,
                   help="processes for the cases (default 2)")
    p.add_argument("--out", default="results", metavar="DIR", help="results folder (default: results)")
    p.set_defaults(func=commands.cmd_run)

    p = command(sub, "campaign", help="Monte Carlo over noise seeds and drawn truths, on Dask")
    study_args(p, "realistic", "run's default is reference")
    p.add_argument("--runs", type=_integer(1, _MAX_RUNS, "a number of runs"), required=True, metavar="N",
                   help="number of runs")
    p.add_argument("--dispersed", action="store_true", help="draw each run's truth from the scenario's [uncertainty]")
    p.add_argument("--truth-scenario", default=None, metavar="PATH",
                   help="one truth for every run from this scenario (not with --dispersed)")
    p.add_argument("--cases", type=_cases, default=("dual", "joint"), metavar="A,B,...",
                   help="cases to run, among {cases} (default: the recommended dual,joint)")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="a running Dask scheduler (default: a local cluster)")
    p.add_argument("--workers", type=_integer(0, _MAX_WORKERS, "a number of processes"), default=2, metavar="K",
                   help="worker processes of the local cluster; 0 runs in this process (default 2)")
    p.add_argument("--out", required=True, metavar="DIR", help="results folder; a campaign started again resumes there")
    p.add_argument("--fresh", action="store_true", help="discard runs saved in DIR instead of resuming")
    p.set_defaults(func=commands.cmd_campaign)

    p = command(sub, "simulate", help="truth simulation to a NetCDF file")
    scenario_args(p)
    p.add_argument("--duration", type=_positive_float, default=None, metavar="S", help="seconds (default: scenario)")
    p.add_argument("--integrator", choices=INTEGRATORS, default=None, help="(default: the scenario's)")
    p.add_argument("--step", type=_positive_float, default=None, metavar="H", help="integrator step (s)")
    p.add_argument("--undamped", action="store_true", help="set every damper to zero")
    p.add_argument("--free", action="store_true", help="no excitation inputs")
    p.add_argument("--out", default=None, metavar="FILE", help="NetCDF output (default: results/simulate_<scenario>_<variant>.nc)")
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")
    p.set_defaults(func=commands.cmd_simulate)

    p = command(sub, "modes", help="natural frequencies and what moves in each mode")
    scenario_args(p)
    p.add_argument("--count", type=_integer(1, _MAX_MODES, "a number of modes"), default=20,
                   help="number of modes to list (default 20)")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=commands.cmd_modes)

    p = command(sub, "scenario", help="scenario files: show a built-in one, start one of your own, validate one")
    scenario_sub = p.add_subparsers(dest="scenario_command", required=True, parser_class=_Parser)
    c = command(scenario_sub, "show", help="print a built-in scenario (or a file) as TOML")
    c.add_argument("name", metavar="NAME|FILE")
    c.set_defaults(func=commands.cmd_scenario_show)
    c = command(scenario_sub, "new", help="write a scenario file to edit, a copy of a built-in one")
    c.add_argument("--like", default="envisat", metavar="NAME", help="the built-in scenario to start from")
    c.add_argument("-o", "--output", required=True, metavar="FILE.toml")
    c.set_defaults(func=commands.cmd_scenario_new)
    c = command(scenario_sub, "validate", help="check a scenario file; every problem with its path (exit status: "
                                               "their number)")
    c.add_argument("file", metavar="FILE")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=commands.cmd_scenario_validate)
    c = command(scenario_sub, "reference", help="the reference of every field: unit, default, bounds (Markdown)")
    c.set_defaults(func=commands.cmd_scenario_reference)

    p = command(sub, "panel", help="panel models: calibrate the lumped chain against a plate FEM")
    panel_sub = p.add_subparsers(dest="panel_command", required=True, parser_class=_Parser)
    c = command(panel_sub, "calibrate", help="fit the lumped panel stiffnesses to the FEM and validate by a sine sweep")
    c.add_argument("--panel", default="envisat", help="envisat, chaser, or a TOML file with geometry and laminate")
    c.add_argument("--segments", type=_segments, default=5, metavar="N", help="rigid segments (default 5)")
    c.add_argument("--weights", type=_weights, default=(1.0, 10.0, 0.1), metavar="W1,W2,...",
                   help="mode-shape weights of the fit, one run each (default 1,10,0.1)")
    c.add_argument("--reference", default="fem", metavar="fem|OP2FILE",
                   help="the built-in plate FEM, or modes read from a Nastran OP2 file")
    c.add_argument("--out", default=None, metavar="DIR", help="write tables, JSON, a TOML fragment and figures here")
    c.add_argument("--force-reference", action="store_true",
                   help="use an OP2 reference even beyond the tolerance of the project's own FEM (mass, frequencies)")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=commands.cmd_panel_calibrate)

    p = command(sub, "fmu", help="FMI: export the plant as a co-simulation FMU, inspect an FMU")
    fmu_sub = p.add_subparsers(dest="fmu_command", required=True, parser_class=_Parser)
    c = command(fmu_sub, "export", help="build an FMI 2.0 or 3.0 co-simulation FMU (compiled C) of the scenario's "
                                        "plant or, with --estimator, of a recommended estimator")
    c.add_argument("--scenario", default="envisat")
    c.add_argument("--variant", default="flexible", choices=VARIANTS)
    c.add_argument("--fmi", type=int, default=2, choices=[2, 3], help="FMI version: 2 (2.0) or 3 (3.0)")
    c.add_argument("--panel-segments", type=_segments, default=None, metavar="N")
    c.add_argument("--no-directional", action="store_true", help="without directional derivatives")
    c.add_argument("--no-step-jacobian", action="store_true", help="without the exact step-Jacobian outputs")
    c.add_argument("--estimator", default=None, choices=("joint", "dual", "ekf_flexible", "mekf_flexible"),
                   metavar="CASE",
                   help="instead of the plant: the estimator of a case, one doStep per filter cycle, in the FMI "
                        "version of --fmi: a recommended one (joint, dual) or the reference's dual scheme with its "
                        "EKF or MEKF (ekf_flexible, mekf_flexible)")
    c.add_argument("--profile", default="reference", choices=("reference", "realistic"),
                   help="with --estimator: the sensor profile whose tuning it carries")
    c.add_argument("--ssp", action="store_true",
                   help="with --estimator: an SSP archive (-o FILE.ssp) of the plant FMU and the estimator FMU, "
                        "connected, for OMSimulator (FMI 2.0)")
    c.add_argument("-o", "--output", required=True, metavar="FILE.fmu|FILE.ssp")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=commands.cmd_fmu_export)
    c = command(fmu_sub, "info", help="variables, capabilities and what a filter mapping needs")
    c.add_argument("fmu", metavar="FILE.fmu")
    c.add_argument("--map", default=None, metavar="MAP.toml")
    c.add_argument("--json", action="store_true")
    c.set_defaults(func=commands.cmd_fmu_info)

    p = command(sub, "bench", help="speed benchmark (real-time factors, step Jacobian, build time)")
    p.add_argument("--scenario", default="envisat")
    p.add_argument("--duration", type=_positive_float, default=300.0, metavar="S", help="simulated seconds per case")
    p.add_argument("--accuracy", action="store_true",
                   help="instead: integrator accuracy against RK4 at 0.25 ms (40 s forced and free; minutes)")
    p.add_argument("--campaign", action="store_true",
                   help="also time a 50-run dispersed campaign of dual and joint (key campaign50_s; minutes)")
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


class _NoteFormatter(logging.Formatter):
    """Without ``-v``: the library's warnings as ``postcapture: note: ...`` lines (one per event)."""

    def format(self, record):
        text = record.getMessage()
        if not record.name.startswith("postcapture"):  # another library's: say whose
            return f"{record.levelname.lower()} ({record.name}): {text}"
        if record.levelno >= logging.ERROR:
            return f"postcapture: {record.levelname.lower()}: {text}"
        return f"postcapture: note: {text}"


def _configure_logging(verbose: bool) -> None:
    handler = logging.StreamHandler()
    if verbose:
        handler.setFormatter(logging.Formatter("%(levelname)s %(name)s: %(message)s"))
    else:
        handler.setFormatter(_NoteFormatter())
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, handlers=[handler])


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``postcapture`` console script; returns the exit status.

    Everything from parsing on runs under the top-level handler: a Ctrl-C at any moment gives one line
    and status 130.
    """
    _single_threaded()
    previous = None
    verbose = argv is not None and ("-v" in argv or "--verbose" in argv)
    try:
        if threading.current_thread() is threading.main_thread():
            previous = signal.signal(signal.SIGTERM, _on_sigterm)
        args = build_parser().parse_args(argv)
        verbose = args.verbose
        _configure_logging(args.verbose)
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
        return _report(exc, verbose)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    from postcapture._console import run

    sys.exit(run())
