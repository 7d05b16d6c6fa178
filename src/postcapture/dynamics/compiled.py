"""Build, cache and load the compiled plant core (``dynamics/csrc``, plain C99 and libm).

The core is data-driven (any scenario runs on the same binary), so it is compiled once per machine and
package version with the system C compiler, into a user cache directory, and loaded with :mod:`ctypes`:
no Python headers, no per-scenario code generation. The cache key is a hash of the sources, the compiler
and its flags. ``POSTCAPTURE_CACHE`` overrides the cache directory and ``CC`` the compiler.

A failure (no compiler, a compiler error, a cache that cannot be written, a library that cannot be
loaded) raises :class:`postcapture.core.errors.CompileError` naming the cause and the fix; nothing falls
back silently to the Python reference integrators.
"""

from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import time
from importlib import resources
from pathlib import Path

from postcapture.core.errors import CompileError

__all__ = ["SOURCES", "CFLAGS", "source_files", "cache_dir", "compiler", "load_library", "compile_seconds"]

logger = logging.getLogger(__name__)

SOURCES = ("pc_model.c", "pc_dynamics.c", "pc_derivatives.c", "pc_integrator.c", "pc_jacobian.c")
HEADERS = ("pc_plant.h", "pc_internal.h")
# The FMU export compiles the same sources with the same flags, so both run the same arithmetic.
CFLAGS = ("-O3", "-std=c99", "-fPIC", "-ffp-contract=off", "-fvisibility=hidden")
_EXPORTED = "__attribute__((visibility(\"default\")))"

_LIB: ctypes.CDLL | None = None
_COMPILE_S = 0.0


def source_files() -> dict[str, str]:
    """The core's C sources and headers by file name."""
    root = resources.files("postcapture.dynamics") / "csrc"
    return {name: (root / name).read_text() for name in SOURCES + HEADERS}


def cache_dir() -> Path:
    """Where compiled cores are kept: ``$POSTCAPTURE_CACHE``, else ``$XDG_CACHE_HOME/postcapture``."""
    env = os.environ.get("POSTCAPTURE_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "postcapture"


def compiler() -> str:
    """The C compiler: ``$CC``, else ``gcc`` or ``cc`` on the PATH."""
    for cand in (os.environ.get("CC"), "gcc", "cc"):
        if cand and shutil.which(cand):
            return str(shutil.which(cand))
    raise CompileError(
        "the compiled plant core needs a C compiler and none was found (tried $CC, gcc, cc): "
        "install gcc (e.g. `apt-get install gcc`) or set CC to a C99 compiler"
    )


def _compiler_id(cc: str) -> str:
    try:
        out = subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=30).stdout
    except (OSError, subprocess.SubprocessError) as exc:
        raise CompileError(f"the C compiler {cc} cannot be run ({exc}): install gcc or set CC") from exc
    return out.splitlines()[0] if out else cc


def _build(cc: str, files: dict[str, str], target: Path) -> float:
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="postcapture_core_") as tmp:
        src = Path(tmp)
        for name, text in files.items():
            (src / name).write_text(text)
        out = src / target.name
        cmd = [cc, *CFLAGS, "-shared", "-o", str(out), *(str(src / n) for n in SOURCES), "-lm"]
        logger.info("compiling the plant core: %s", " ".join(cmd))
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            raise CompileError(
                f"compiling the plant core with {cc} failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}\n"
                "fix: use a C99 compiler (gcc >= 5 or clang), e.g. set CC=gcc"
            )
        try:
            target.parent.mkdir(parents=True, exist_ok=True)
            tmp_target = target.with_name(f".{target.name}.{os.getpid()}.tmp")
            shutil.copyfile(out, tmp_target)
            os.replace(tmp_target, target)
        except OSError as exc:
            raise CompileError(
                f"the plant-core cache {target.parent} is not writable ({exc.strerror}): "
                "set POSTCAPTURE_CACHE to a writable directory"
            ) from exc
    return time.perf_counter() - t0


def load_library() -> ctypes.CDLL:
    """The compiled core, built on first use (a few seconds) and cached; see the module docstring."""
    global _LIB, _COMPILE_S
    if _LIB is not None:
        return _LIB
    if not sys.platform.startswith("linux") and sys.platform != "darwin":
        raise CompileError(f"the compiled plant core is built for Linux and macOS, not {sys.platform}")
    files = source_files()
    cc = compiler()
    key = hashlib.sha256()
    for name in sorted(files):
        key.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    key.update(" ".join(CFLAGS).encode() + _compiler_id(cc).encode() + sys.platform.encode())
    target = cache_dir() / f"pc_core_{key.hexdigest()[:16]}.so"
    if not target.exists():
        _COMPILE_S = _build(cc, files, target)
        logger.info("plant core compiled in %.2f s into %s", _COMPILE_S, target)
    try:
        lib = ctypes.CDLL(str(target))
    except OSError as exc:
        raise CompileError(
            f"the compiled plant core {target} cannot be loaded ({exc}): delete it to rebuild, "
            "or set POSTCAPTURE_CACHE to another directory"
        ) from exc
    _declare(lib)
    _LIB = lib
    return lib


def compile_seconds() -> float:
    """Seconds this process spent compiling the core (0 when it came from the cache)."""
    return _COMPILE_S


def _declare(lib: ctypes.CDLL) -> None:
    P, I, D = ctypes.c_void_p, ctypes.c_int, ctypes.c_double
    sigs = {
        "pc_create": (P, [P, P, ctypes.c_size_t, ctypes.c_size_t]),
        "pc_destroy": (None, [P]),
        "pc_error_message": (ctypes.c_char_p, [P]),
        "pc_sizes": (I, [P, P]),
        "pc_set_params": (I, [P, P]),
        "pc_get_params": (I, [P, P]),
        "pc_set_input_offset": (None, [P, P]),
        "pc_set_tableau": (I, [P, I, P, P, P]),
        "pc_set_newton": (None, [P, D, D, I]),
        "pc_stats": (None, [P, P]),
        "pc_reset_stats": (None, [P]),
        "pc_inputs": (None, [P, D, I, P]),
        "pc_inputs_eval": (I, [I, P, P, I, P, P, I, I, P, I, P]),
        "pc_force": (None, [P, P, P, P, P]),
        "pc_aba": (I, [P, P, P, P, P]),
        "pc_rnea": (I, [P, P, P, P, P]),
        "pc_accel": (I, [P, P, P, P, P]),
        "pc_integrate": (I, [P, P, P, P]),
        "pc_derivatives": (I, [P, P, P, P, P, P, P, P, P]),
        "pc_mass_matrix": (I, [P, P, P]),
        "pc_measure": (I, [P, P, P, D, P, P, P, P]),
        "pc_sample": (I, [P, P, P, D, P, P, P]),
        "pc_step": (I, [P, P, P, D, D, P]),
        "pc_step_jacobian": (I, [P, P, P, D, D, P, P, P]),
        "pc_simulate": (I, [P, P, P, D, D, D, I, I, I, P, P, P, P, P, P, P, P]),
        "pc_predict": (I, [P, P, P, D, D, I, I, P, P, P, P, P, P, P]),
    }
    for name, (res, args) in sigs.items():
        fn = getattr(lib, name)
        fn.restype = res
        fn.argtypes = args
