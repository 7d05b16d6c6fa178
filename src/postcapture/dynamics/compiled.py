"""Build, cache, verify and load the compiled plant core (``dynamics/csrc``, plain C99 and libm).

The core is data-driven (any scenario runs on the same binary), so it is compiled once per machine and
package version with the system C compiler, into a user cache directory, and loaded with :mod:`ctypes`:
no Python headers, no per-scenario code generation. The cache key is a hash of the sources, the compiler
and its flags. ``POSTCAPTURE_CACHE`` overrides the cache directory and ``CC`` the compiler.

A cached library is trusted only after checking it: it must be a regular file whose SHA-256 matches
the one recorded when it was built (``<name>.sha256`` beside it), and once loaded it must report the
build key it was compiled with. A truncated, overwritten or foreign file, a FIFO or a stray link at the
path is removed and rebuilt; what cannot be removed (a folder) is refused with one message naming the
path and the fix. Builds are serialised across processes by a lock file, and builds that no process
has loaded for :data:`PRUNE_DAYS` days (or beyond the :data:`KEEP_BUILDS` most recently used) are
pruned: other checkouts' recent builds are kept.

A failure (no compiler, ``CC`` naming no working compiler, a compiler error, a cache that cannot be
written) raises :class:`postcapture.core.errors.CompileError` naming the cause and the fix; nothing
falls back silently.
"""

from __future__ import annotations

import ctypes
import fcntl
import hashlib
import logging
import os
import shutil
import stat
import subprocess
import sys
import tempfile
import time
from contextlib import contextmanager
from importlib import resources
from pathlib import Path

from postcapture.core.errors import CompileError

__all__ = ["SOURCES", "FILTER_SOURCES", "HEADERS", "CFLAGS", "source_files", "cache_dir", "compiler", "load_library",
           "compile_seconds", "prune_cache", "PRUNE_DAYS", "KEEP_BUILDS"]

logger = logging.getLogger(__name__)

SOURCES = ("pc_model.c", "pc_validate.c", "pc_data.c", "pc_inputs.c", "pc_passive.c", "pc_kinematics.c", "pc_aba.c",
           "pc_rnea.c", "pc_rnea_derivatives.c", "pc_crba.c", "pc_derivatives.c", "pc_liegroup.c", "pc_linalg.c",
           "pc_integrator.c", "pc_jacobian.c", "pc_gravity.c")
# the filters' arithmetic (pc_filter.h): compiled into the same library, and into the estimator FMUs
FILTER_SOURCES = ("pc_recovery.c", "pc_kalman.c", "pc_so3.c", "pc_increments.c", "pc_parameters.c", "pc_mekf.c",
                  "pc_attitude_ekf.c", "pc_mass_filter.c", "pc_augmented.c", "pc_refdual.c")
HEADERS = ("pc_plant.h", "pc_internal.h", "pc_spatial.h", "pc_filter.h", "pc_filter_internal.h")
# The FMU export compiles the same sources with the same flags, so both run the same arithmetic.
CFLAGS = ("-O3", "-std=c99", "-fPIC", "-ffp-contract=off", "-fvisibility=hidden")
PRUNE_DAYS = 30.0  # a build not loaded for this long is removed
KEEP_BUILDS = 24  # and at most this many builds are kept (the most recently loaded)

_LIB: ctypes.CDLL | None = None
_COMPILE_S = 0.0


def source_files() -> dict[str, str]:
    """The core's C sources and headers by file name."""
    root = resources.files("postcapture.dynamics") / "csrc"
    return {name: (root / name).read_text() for name in SOURCES + FILTER_SOURCES + HEADERS}


def cache_dir() -> Path:
    """Where compiled cores are kept: ``$POSTCAPTURE_CACHE``, else ``$XDG_CACHE_HOME/postcapture``."""
    env = os.environ.get("POSTCAPTURE_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "postcapture"


def compiler() -> str:
    """The C compiler: ``$CC`` when set (it must name a compiler on the PATH), else ``gcc`` or ``cc``."""
    cc = os.environ.get("CC")
    if cc:
        found = shutil.which(cc)
        if not found:
            raise CompileError(f"CC={cc!r} names no C compiler on the PATH: set CC to a C99 compiler (e.g. CC=gcc) "
                               "or unset it")
        return found
    for cand in ("gcc", "cc"):
        if shutil.which(cand):
            return str(shutil.which(cand))
    raise CompileError(
        "the compiled plant core needs a C compiler and none was found (tried $CC, gcc, cc): "
        "install gcc (e.g. `apt-get install gcc`) or set CC to a C99 compiler"
    )


def _compiler_id(cc: str) -> str:
    try:
        proc = subprocess.run([cc, "--version"], capture_output=True, text=True, timeout=30, stdin=subprocess.DEVNULL)
    except (OSError, subprocess.SubprocessError) as exc:
        raise CompileError(f"the C compiler {cc} cannot be run ({exc}): install gcc or set CC to a C99 compiler") from exc
    if proc.returncode != 0 or not proc.stdout.strip():
        raise CompileError(f"the C compiler {cc} does not work (`{cc} --version` exited {proc.returncode}): "
                           "set CC to a C99 compiler (e.g. CC=gcc)")
    return proc.stdout.splitlines()[0]


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def _build(cc: str, files: dict[str, str], target: Path, build_id: str = "unversioned") -> float:
    """Compile the core into ``target`` (atomically) and record its hash beside it; returns seconds."""
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="postcapture_core_") as tmp:
        src = Path(tmp)
        for name, text in files.items():
            (src / name).write_text(text)
        out = src / "core.so"
        cmd = [cc, *CFLAGS, f"-DPC_BUILD_ID=\"{build_id}\"", "-shared", "-o", str(out),
               *(str(src / n) for n in SOURCES + FILTER_SOURCES), "-lm"]
        logger.info("compiling the plant core: %s", " ".join(cmd))
        proc = subprocess.run(cmd, capture_output=True, text=True, stdin=subprocess.DEVNULL)
        if proc.returncode != 0:
            raise CompileError(
                f"compiling the plant core with {cc} failed (exit {proc.returncode}):\n{proc.stderr[-3000:]}\n"
                "fix: use a C99 compiler (gcc >= 5 or clang), e.g. set CC=gcc"
            )
        data = out.read_bytes()
        try:
            _write_atomic(target, data)
            _write_atomic(_hash_path(target), hashlib.sha256(data).hexdigest().encode())
        except OSError as exc:
            raise CompileError(
                f"the plant-core cache {target.parent} is not writable ({exc.strerror}): "
                "set POSTCAPTURE_CACHE to a writable directory"
            ) from exc
    return time.perf_counter() - t0


def _hash_path(target: Path) -> Path:
    return target.with_name(target.name + ".sha256")


def _problem(target: Path) -> str | None:
    """Why the file at ``target`` is not a trustworthy build (None when it is)."""
    try:
        st = os.lstat(target)
    except FileNotFoundError:
        return "missing"
    if not stat.S_ISREG(st.st_mode):
        return "not a regular file"
    try:
        recorded = _hash_path(target).read_text().strip()
    except OSError:
        return "no recorded hash"
    if _sha256(target) != recorded:
        return "its hash differs from the one recorded at build (truncated, overwritten or foreign)"
    return None


def _remove(target: Path) -> None:
    """Remove what is at ``target`` (file, FIFO, link); refuse a folder with one message."""
    try:
        st = os.lstat(target)
    except FileNotFoundError:
        return
    if stat.S_ISDIR(st.st_mode):
        raise CompileError(f"the compiled plant core's path {target} is a folder: remove it "
                           "(or set POSTCAPTURE_CACHE to another directory)")
    try:
        os.unlink(target)
    except OSError as exc:
        raise CompileError(f"the compiled plant core {target} is damaged and cannot be removed ({exc.strerror}): "
                           "delete it, or set POSTCAPTURE_CACHE to another directory") from exc


@contextmanager
def _cache_lock(folder: Path):
    """Serialise building, checking and pruning across processes (an advisory lock file)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        fd = os.open(folder / ".lock", os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise CompileError(f"the plant-core cache {folder} is not writable ({exc.strerror}): "
                           "set POSTCAPTURE_CACHE to a writable directory") from exc
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def prune_cache(folder: Path, keep: Path | None = None, *, days: float = PRUNE_DAYS, max_builds: int = KEEP_BUILDS,
                now: float | None = None) -> list[Path]:
    """Remove builds not loaded for ``days`` days, and the least recently loaded beyond ``max_builds``.

    A build's last use is the time its hash file was last touched (every load touches it); ``keep``
    (the build being loaded) is never removed. Returns the removed libraries.
    """
    now = time.time() if now is None else now
    builds = []
    for lib in folder.glob("pc_core_*.so"):
        if keep is not None and lib.name == keep.name:
            continue
        try:
            used = os.lstat(_hash_path(lib)).st_mtime
        except OSError:
            used = os.lstat(lib).st_mtime
        builds.append((used, lib))
    builds.sort(reverse=True)
    limit = max_builds - (1 if keep is not None else 0)
    removed = []
    for rank, (used, lib) in enumerate(builds):
        if now - used > days * 86400.0 or rank >= limit:
            for p in (lib, _hash_path(lib)):
                try:
                    os.unlink(p)
                except OSError:
                    pass
            removed.append(lib)
    return removed


def _key(cc: str, files: dict[str, str]) -> str:
    key = hashlib.sha256()
    for name in sorted(files):
        key.update(name.encode() + b"\0" + files[name].encode() + b"\0")
    key.update(" ".join(CFLAGS).encode() + _compiler_id(cc).encode() + sys.platform.encode())
    return key.hexdigest()[:16]


def _ensure_built(cc: str, files: dict[str, str], target: Path, key: str) -> None:
    """Check the cached build under the lock; rebuild what is damaged, missing or foreign."""
    global _COMPILE_S
    with _cache_lock(target.parent):
        problem = _problem(target)
        if problem is not None:
            if problem != "missing":
                logger.warning("the compiled plant core %s is unusable (%s): rebuilding it", target, problem)
            _remove(target)
            _COMPILE_S = _build(cc, files, target, key)
            logger.info("plant core compiled in %.2f s into %s", _COMPILE_S, target)
            problem = _problem(target)
            if problem is not None:
                raise CompileError(f"the compiled plant core {target} is unusable right after building it ({problem}): "
                                   "set POSTCAPTURE_CACHE to another directory")
        os.utime(_hash_path(target))  # last use, for pruning
        for gone in prune_cache(target.parent, keep=target):
            logger.info("pruned the unused plant core %s", gone)


def load_library() -> ctypes.CDLL:
    """The compiled core, built on first use (a few seconds), cached and verified; see the module docstring."""
    global _LIB
    if _LIB is not None:
        return _LIB
    if not sys.platform.startswith("linux") and sys.platform != "darwin":
        raise CompileError(f"the compiled plant core is built for Linux and macOS, not {sys.platform}")
    files = source_files()
    cc = compiler()
    key = _key(cc, files)
    target = cache_dir() / f"pc_core_{key}.so"
    _ensure_built(cc, files, target, key)
    try:
        lib = ctypes.CDLL(str(target))
        fn = lib.pc_build_id
    except (OSError, AttributeError) as exc:
        raise CompileError(
            f"the compiled plant core {target} cannot be loaded ({exc}): delete it to rebuild, "
            "or set POSTCAPTURE_CACHE to another directory"
        ) from exc
    fn.restype, fn.argtypes = ctypes.c_char_p, []
    if fn() != key.encode():
        raise CompileError(f"the library at {target} is not the plant core it should be (build id "
                           f"{fn()!r}, expected {key!r}): delete it to rebuild")
    _LIB = lib
    return lib


def compile_seconds() -> float:
    """Seconds this process spent compiling the core (0 when it came from the cache)."""
    return _COMPILE_S
