"""The exported plant in third-party FMI tools built on this machine: the FMI Compliance Checker,
OMSimulator and the Reference FMUs' fmusim (``/work/tools/README.md``). Each test is skipped where its tool
is absent (a fresh CI machine); the directory is ``$POSTCAPTURE_FMI_TOOLS`` or ``/work/tools/bin``, else
the tool's name on ``PATH``. Every trajectory is checked against the native process model taking the same
internal steps."""

import csv
import os
import shutil
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from fmi_helpers import native_trajectory, rel, state_names  # noqa: E402

from postcapture.dynamics.build import build_system  # noqa: E402

TIMEOUT = 600  # s: a loaded machine; the runs take seconds


def _tool(name: str) -> str:
    folder = Path(os.environ.get("POSTCAPTURE_FMI_TOOLS", "/work/tools/bin"))
    path = folder / name if (folder / name).is_file() else shutil.which(name)
    if not path:
        pytest.skip(f"{name} not found in {folder} nor on PATH (built by hand, see /work/tools/README.md)")
    return str(path)


def _read_csv(path: Path, names: list[str]):
    """Time and the named columns of a master's CSV (quoted or bare names); rows repeated at one time
    (OMSimulator writes each communication point before and after its step) are kept once."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header = [h.strip().strip('"') for h in rows[0]]
    col = {h: i for i, h in enumerate(header)}
    data = np.array([[float(v) for v in r] for r in rows[1:] if r])
    t, keep = np.unique(data[:, 0], return_index=True)
    return t, data[keep][:, [col[n] for n in names]].T


@pytest.mark.parametrize("step", [None, 0.01])
def test_compliance_checker(envisat_fmu, envisat, tmp_path, step):
    """0 errors and 0 warnings at the checker's default step (10 s / 500 = 0.02 s) and at 0.01 s."""
    exe = _tool("fmuCheck")
    log, out = tmp_path / "check.log", tmp_path / "check.csv"
    args = [exe, "-l", "3", "-s", "10", "-o", str(out), "-e", str(log), "-t", str(tmp_path), "-f"]
    if step is not None:
        args[1:1] = ["-h", str(step)]
    proc = subprocess.run([*args, str(envisat_fmu.path)], capture_output=True, text=True, timeout=TIMEOUT)
    text = log.read_text()
    assert proc.returncode == 0, text[-2000:]
    summary = " ".join(text[text.index("FMU check summary"):].split())
    assert "FMU reported: 0 warning(s) and error(s)" in summary and "0 Warning(s) 0 Error(s)" in summary, summary
    system = build_system(envisat)
    names = state_names(system)
    t, Y = _read_csv(out, names)
    dt = step or 0.02
    X = native_trajectory(system, envisat_fmu, 10.0, dt)
    # the checker's rows sit on its output grid (at most 500 points): compare those instants
    k = np.rint(t / dt).astype(int)
    assert np.abs(t - k * dt).max() < 1e-9 and t[-1] == pytest.approx(10.0)
    assert rel(Y, X[:, k]) <= 1e-12


def test_omsimulator(envisat_fmu, envisat, tmp_path):
    """OMSimulator records every output (the Jacobians are finite now), takes its last 1.95e-14 s step, and
    loads the FMU in seconds (about 90 s of CPU when no initial unknown listed its dependencies)."""
    exe = _tool("OMSimulator")
    out = tmp_path / "oms.csv"
    t0 = time.perf_counter()
    proc = subprocess.run([exe, "--stopTime=10", "--stepSize=0.1", "--intervals=100", f"--resultFile={out}",
                           f"--tempDir={tmp_path}", str(envisat_fmu.path)], capture_output=True, text=True,
                          timeout=TIMEOUT, cwd=tmp_path)
    wall = time.perf_counter() - t0
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0 and "error" not in text.lower(), text[-3000:]
    system = build_system(envisat)
    names = state_names(system)
    t, Y = _read_csv(out, names)
    X = native_trajectory(system, envisat_fmu, 10.0, 0.1)
    assert t.size == 101 and t[-1] == pytest.approx(10.0)
    assert rel(Y, X) <= 1e-10  # OMSimulator's CSV holds 12 significant digits
    assert wall < 60.0, wall


@pytest.mark.parametrize("which, dt", [("fmi2", 0.1), ("fmi3", 0.1), ("fmi3", 0.01)])
def test_fmusim(envisat_fmu, envisat_fmu3, envisat, tmp_path, which, dt):
    """The Reference FMUs' master runs the FMI 2.0 and 3.0 FMUs (0.01 s: shorter than the internal step)."""
    exe = _tool("fmusim")
    report = envisat_fmu3 if which == "fmi3" else envisat_fmu
    out = tmp_path / "fmusim.csv"
    proc = subprocess.run([exe, "--interface-type", "cs", "--stop-time", "10", "--output-interval", str(dt),
                           "--log-level", "warning", "--output-file", str(out), str(report.path)],
                          capture_output=True, text=True, timeout=TIMEOUT)
    assert proc.returncode == 0 and not proc.stdout.strip() and not proc.stderr.strip(), proc.stdout + proc.stderr
    system = build_system(envisat)
    t, Y = _read_csv(out, state_names(system))
    X = native_trajectory(system, report, 10.0, dt)
    assert Y.shape == X.shape and t[-1] == pytest.approx(10.0)
    assert rel(Y, X) <= 1e-12
