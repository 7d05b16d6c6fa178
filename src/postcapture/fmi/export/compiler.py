"""Compile an FMU's C sources into its shared library with the system C compiler, and zip the FMU.

The sources are the compiled plant core (``dynamics/csrc``), the FMI wrapper and the generated data
header, compiled with the core's flags, two compiler processes at most. Only the FMI functions are
exported (``-fvisibility=hidden``, ``-Wl,-Bsymbolic``), so several of these FMUs coexist in one process.
"""

from __future__ import annotations

import logging
import os
import subprocess
import zipfile
from pathlib import Path

from postcapture.core.errors import FMIError

__all__ = ["platform_folder", "find_compiler", "compile_library", "zip_fmu"]

logger = logging.getLogger(__name__)


def platform_folder(fmi_version: int = 2) -> tuple[str, str]:
    """Binary folder (FMI 2.0: ``linux64``; FMI 3.0: ``x86_64-linux``) and shared-library suffix of this machine."""
    from postcapture.fmi.export.versions import VERSIONS

    return VERSIONS[fmi_version].binary_folder(), ".so"


def find_compiler() -> str:
    """The C compiler (the compiled core's choice: ``$CC``, else ``gcc`` or ``cc``)."""
    from postcapture.core.errors import CompileError
    from postcapture.dynamics.compiled import compiler

    try:
        return compiler()
    except CompileError as exc:
        raise FMIError(str(exc), function="compile") from exc


def _run(cmd: list[str], cwd: Path) -> subprocess.Popen:
    logger.debug("%s", " ".join(cmd))
    return subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


def _wait(proc: subprocess.Popen, what: str, fmu: str) -> None:
    out, _ = proc.communicate()
    if proc.returncode != 0:
        raise FMIError(f"compiling {what} failed:\n{out[-4000:]}\nfix: use a C99 compiler (gcc >= 5 or clang), "
                       "e.g. set CC=gcc", fmu=fmu, function="compile")


def compile_library(sources: Path, build: Path, out: Path, *, fmu: str = "") -> float:
    """Compile every ``*.c`` in ``sources`` (two at a time) and link ``out``; returns the wall time (s).

    The flags are the compiled core's (:data:`postcapture.dynamics.compiled.CFLAGS`), so the FMU runs the
    same arithmetic as the native process model; the core's symbols stay hidden (``PC_API`` empty).
    """
    import time

    from postcapture.dynamics.compiled import CFLAGS

    cc = find_compiler()
    common = ["-c", *CFLAGS, "-DPC_API=", "-w", "-I", str(sources)]
    build.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    files = sorted(p.name for p in sources.glob("*.c"))
    running: list = []
    try:
        for name in files:
            running.append((_run([cc, *common, str(sources / name), "-o", str(build / (name + ".o"))], build), name))
            if len(running) == 2:
                proc, what = running.pop(0)
                _wait(proc, what, fmu)
        for proc, what in running:
            _wait(proc, what, fmu)
    except BaseException:
        for proc, _ in running:
            proc.kill()
            proc.wait()
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
