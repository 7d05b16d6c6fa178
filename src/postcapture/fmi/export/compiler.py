"""Compile an FMU's C sources into its shared library with the system C compiler, and zip the FMU.

The large generated Jacobian file is compiled with ``-O1`` (at ``-O2`` gcc takes minutes on it) in
parallel with the rest (``-O2``): two compiler processes at most. Only the FMI functions are exported
(``-fvisibility=hidden``, ``-Wl,-Bsymbolic``), so several of these FMUs coexist in one process.
"""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

from postcapture.core.errors import FMIError

__all__ = ["platform_folder", "find_compiler", "compile_library", "zip_fmu"]

logger = logging.getLogger(__name__)


def platform_folder() -> tuple[str, str]:
    """FMI 2.0 binary folder and shared-library suffix of this machine."""
    if sys.platform.startswith("linux"):
        return ("linux64" if sys.maxsize > 2**32 else "linux32"), ".so"
    raise FMIError(f"exporting FMUs is supported on Linux only, not {sys.platform}", function="export")


def find_compiler() -> str:
    """The C compiler: ``$CC`` or ``gcc`` or ``cc``."""
    for cand in (os.environ.get("CC"), "gcc", "cc"):
        if cand and shutil.which(cand):
            return shutil.which(cand)
    raise FMIError("no C compiler found (set CC or install gcc)", function="compile")


def _run(cmd: list[str], cwd: Path) -> subprocess.Popen:
    logger.debug("%s", " ".join(cmd))
    return subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _wait(proc: subprocess.Popen, what: str, fmu: str) -> None:
    out, _ = proc.communicate()
    if proc.returncode != 0:
        raise FMIError(f"compiling {what} failed:\n{out[-4000:]}", fmu=fmu, function="compile")


def compile_library(sources: Path, build: Path, out: Path, *, jac_file: str, fmu: str = "") -> float:
    """Compile every ``*.c`` in ``sources`` and link ``out``; returns the wall time (s)."""
    import time

    cc = find_compiler()
    include = ["-I", str(sources)]
    common = ["-c", "-fPIC", "-std=c99", "-fvisibility=hidden", "-w"]
    build.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    files = sorted(p.name for p in sources.glob("*.c"))
    big = _run(
        [cc, *common, "-O1", *include, str(sources / jac_file), "-o", str(build / (jac_file + ".o"))], build
    )
    try:
        for name in files:
            if name == jac_file:
                continue
            _wait(
                _run(
                    [cc, *common, "-O2", *include, str(sources / name), "-o", str(build / (name + ".o"))],
                    build,
                ),
                name,
                fmu,
            )
        _wait(big, jac_file, fmu)
    except BaseException:
        big.kill()
        big.wait()
        raise
    out.parent.mkdir(parents=True, exist_ok=True)
    objects = [str(build / (n + ".o")) for n in files]
    _wait(
        _run([cc, "-shared", "-o", str(out), *objects, "-lm", "-Wl,-Bsymbolic"], build),
        "the shared library",
        fmu,
    )
    return time.perf_counter() - t0


def zip_fmu(root: Path, out: Path) -> None:
    """Zip the FMU tree under ``root`` into ``out`` (written next to it, then renamed)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.tmp")
    with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for path in sorted(root.rglob("*")):
            if path.is_file():
                zf.write(path, path.relative_to(root).as_posix())
    os.replace(tmp, out)
