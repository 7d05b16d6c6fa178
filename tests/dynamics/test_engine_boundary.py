"""The compiled core's boundary: the cached library is verified before loading (damaged, foreign or
non-regular files are rebuilt or refused with one message), CC must name a working compiler, the packed
model is validated index by index, arguments are typed, every failing status raises a typed error, and
nothing is allocated once an instance exists.

Corruption cases run in a child process with its own cache folder and a timeout: a crash would show as
a signal in its return code, a hang as the timeout.
"""

import ctypes
import os
import pickle
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from postcapture.core.errors import CompileError, DomainError, SimulationError
from postcapture.dynamics import compiled
from postcapture.dynamics.build import build_system, initial_state
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.engine import (EngineArgumentError, EngineError, EngineModel, ModelError, NewtonError,
                                         engine)
from postcapture.dynamics.integrators import TABLEAUX
from postcapture.dynamics.packing import pack

LOAD = "from postcapture.dynamics.compiled import load_library; load_library(); print('loaded')"
# The same, with the rebuild replaced by a copy of a good build made by this module (a compile costs
# 5-15 s; the detection and the replacement are what these cases test, one case rebuilds for real)
LOAD_FAST = """
import shutil, sys
from pathlib import Path
from postcapture.dynamics import compiled
good = Path(sys.argv[1])
def copy_build(cc, files, target, build_id="unversioned"):
    shutil.copyfile(good, target)
    shutil.copyfile(good.with_name(good.name + ".sha256"), target.with_name(target.name + ".sha256"))
    return 0.0
compiled._build = copy_build
compiled.load_library()
print('loaded')
"""


def _child(code: str, cache: Path, *args: str, timeout: float = 240.0) -> subprocess.CompletedProcess:
    environ = {**os.environ, "POSTCAPTURE_CACHE": str(cache)}
    return subprocess.run([sys.executable, "-c", code, *args], env=environ, capture_output=True, text=True,
                          timeout=timeout, stdin=subprocess.DEVNULL)


@pytest.fixture(scope="module")
def built_cache(tmp_path_factory) -> Path:
    """A cache folder with one good build in it (compiled once for this module)."""
    cache = tmp_path_factory.mktemp("core_cache")
    proc = _child(LOAD, cache)
    assert proc.returncode == 0, proc.stderr
    return cache


@pytest.fixture
def cache(built_cache, tmp_path) -> Path:
    """A private copy of the built cache (each case damages its own)."""
    folder = tmp_path / "cache"
    shutil.copytree(built_cache, folder)
    return folder


@pytest.fixture(scope="module")
def good_build(built_cache) -> Path:
    return _library(built_cache)


def _library(cache: Path) -> Path:
    (lib,) = cache.glob("pc_core_*.so")
    return lib


def _loads_and_rebuilds(cache: Path, lib: Path, good: Path | None = None) -> None:
    proc = _child(LOAD_FAST, cache, str(good)) if good is not None else _child(LOAD, cache)
    assert proc.returncode == 0, (proc.returncode, proc.stderr)  # never a signal (negative return code)
    assert "loaded" in proc.stdout
    assert "rebuilding" in proc.stderr and str(lib) in proc.stderr
    assert compiled._problem(lib) is None  # the rebuilt file is the recorded one


def test_truncated_library_is_rebuilt(cache):
    lib = _library(cache)
    data = lib.read_bytes()
    lib.write_bytes(data[: len(data) // 3])
    _loads_and_rebuilds(cache, lib)


def test_overwritten_library_is_rebuilt(cache, good_build):
    lib = _library(cache)
    data = bytearray(lib.read_bytes())
    data[len(data) // 2 : len(data) // 2 + 4096] = os.urandom(4096)  # same size, code overwritten
    lib.write_bytes(bytes(data))
    _loads_and_rebuilds(cache, lib, good_build)


def test_foreign_library_is_rebuilt(cache, good_build):
    lib = _library(cache)
    (foreign,) = Path(np.__file__).parent.glob("_core/_multiarray_umath*.so")  # another shared library
    shutil.copyfile(foreign, lib)
    _loads_and_rebuilds(cache, lib, good_build)


def test_foreign_library_with_a_forged_hash_is_refused(cache):
    """Another plant-core build under this name, its hash recorded too: loaded, then refused by its build id."""
    lib = _library(cache)
    data = lib.read_bytes()  # the same core with another build id (same length: patched in place)
    key = lib.stem.removeprefix("pc_core_").encode()
    assert data.count(key) == 1
    lib.write_bytes(data.replace(key, b"x" * len(key)))
    lib.with_name(lib.name + ".sha256").write_text(compiled._sha256(lib))
    proc = _child(LOAD, cache)
    assert proc.returncode == 1 and "CompileError" in proc.stderr
    assert "not the plant core it should be" in proc.stderr and "delete it" in proc.stderr


def test_fifo_at_the_path_is_replaced_not_opened(cache, good_build):
    lib = _library(cache)
    lib.unlink()
    os.mkfifo(lib)
    _loads_and_rebuilds(cache, lib, good_build)


def test_folder_at_the_path_is_refused_with_one_message(cache):
    lib = _library(cache)
    lib.unlink()
    lib.mkdir()
    code = ("from postcapture.core.errors import CompileError\nfrom postcapture.dynamics.compiled import load_library\n"
            "try:\n    load_library()\nexcept CompileError as e:\n    print('ERR', e)\n")
    proc = _child(code, cache)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("ERR") and str(lib) in proc.stdout and "remove it" in proc.stdout


def test_missing_cc_is_one_message_from_the_cli(tmp_path):
    env = {**os.environ, "POSTCAPTURE_CACHE": str(tmp_path), "CC": "/nonexistent/cc"}
    proc = subprocess.run([str(Path(sys.executable).with_name("postcapture")), "modes", "--count", "1"], env=env,
                          capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL)
    assert proc.returncode == 1
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "CC='/nonexistent/cc'" in lines[0] and "Traceback" not in proc.stderr


def test_cc_that_is_no_compiler_is_refused(monkeypatch):
    monkeypatch.setenv("CC", "false")
    with pytest.raises(CompileError, match="does not work"):
        compiled._compiler_id(compiled.compiler())


def test_two_processes_build_one_cache_at_once(tmp_path, good_build):
    """The cache lock: two cold starts at once both load a verified build, none sees a half-written one."""
    env = {**os.environ, "POSTCAPTURE_CACHE": str(tmp_path)}
    procs = [subprocess.Popen([sys.executable, "-c", LOAD_FAST, str(good_build)], env=env, stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, stdin=subprocess.DEVNULL) for _ in range(2)]
    outs = [p.communicate(timeout=240) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    assert len(list(tmp_path.glob("pc_core_*.so"))) == 1


def test_pruning_keeps_recent_builds_and_the_one_in_use(tmp_path):
    now = time.time()
    ages = {"old": 40, "recent": 2, "current": 60}
    for name, days in ages.items():
        lib = tmp_path / f"pc_core_{name}.so"
        lib.write_bytes(b"x")
        stamp = lib.with_name(lib.name + ".sha256")
        stamp.write_text("0")
        os.utime(stamp, (now - days * 86400, now - days * 86400))
    removed = compiled.prune_cache(tmp_path, keep=tmp_path / "pc_core_current.so", now=now)
    assert [p.name for p in removed] == ["pc_core_old.so"]
    assert sorted(p.name for p in tmp_path.glob("*.so")) == ["pc_core_current.so", "pc_core_recent.so"]
    for k in range(5):  # and at most max_builds, the least recently used going first
        (tmp_path / f"pc_core_n{k}.so").write_bytes(b"x")
        os.utime(tmp_path / f"pc_core_n{k}.so", (now - k * 3600, now - k * 3600))
    compiled.prune_cache(tmp_path, keep=tmp_path / "pc_core_current.so", now=now, max_builds=3)
    assert sorted(p.name for p in tmp_path.glob("*.so")) == ["pc_core_current.so", "pc_core_n0.so", "pc_core_n1.so"]


# ------------------------------------------------------------------------- the model and the arguments
@pytest.fixture(scope="module")
def system(envisat):
    return build_system(envisat)


def _spring_offset(packed) -> int:
    nj = int(packed.ints[3])
    return 15 + 4 * nj  # header, then four ints per joint, then the springs


def test_a_spring_index_of_a_million_is_refused_naming_it(system):
    packed = pack(system)
    ints = packed.ints.copy()
    ints[_spring_offset(packed)] = 10**6
    with pytest.raises(ModelError, match=r"spring 0: velocity index 1000000, expected 6 to 24") as info:
        EngineModel(ints, packed.doubles, TABLEAUX["sdirk3"])
    assert info.value.status == 6 and isinstance(info.value, ValueError)


@pytest.mark.parametrize("where,value,match", [
    (3, 10**9, "header entry 3"), (15, 7, "joint 0: parent 7"), (16, 9, "joint 0: kind 9"),
    ("panel", 999, "panel 0: joints"), ("arm", -3, "arm joint 0: velocity index -3"),
])
def test_every_index_of_the_packed_model_is_checked(system, where, value, match):
    packed = pack(system)
    ints = packed.ints.copy()
    n = len(ints)
    if where == "panel":
        where = n - len(system.layout.arm_v) - 3 * len(system.layout.panels)
    elif where == "arm":
        where = n - len(system.layout.arm_v)
    ints[where] = value
    with pytest.raises(ModelError, match=match):
        EngineModel(ints, packed.doubles, TABLEAUX["sdirk3"])


def test_wrong_sizes_and_tableaux_are_refused(system):
    packed = pack(system)
    with pytest.raises(ModelError, match="expected .* ints and .* doubles"):
        EngineModel(packed.ints, packed.doubles[:-1], TABLEAUX["sdirk3"])
    bad = TABLEAUX["sdirk3"]
    upper = type(bad)("upper", bad.A.T.copy(), bad.b, bad.c, 3, False)
    with pytest.raises(ModelError, match="lower triangular"):
        EngineModel(packed.ints, packed.doubles, upper)


def test_arguments_are_typed(system):
    """ctypes itself refuses a list, a wrong dtype or a strided view (ndpointer argument types)."""
    eng, plant = engine(), CompiledPlant(system)
    q, v = initial_state(system)
    out = np.zeros(system.nv)
    with pytest.raises(ctypes.ArgumentError):
        eng.aba(plant._m, plant._d, list(q), v, v, out)
    with pytest.raises(ctypes.ArgumentError):
        eng.aba(plant._m, plant._d, q.astype(np.float32), v, v, out)
    with pytest.raises(ctypes.ArgumentError):
        eng.aba(plant._m, plant._d, q, np.zeros(2 * system.nv)[::2], v, out)


def test_a_failing_status_raises_its_typed_error(system):
    plant = CompiledPlant(system)
    q, v = initial_state(system)
    bad = q.copy()
    bad[8] = np.nan
    with pytest.raises(EngineArgumentError, match=r"pc_step: q\[8\] = nan") as info:
        plant.step(bad, v, 0.0, 0.1)
    assert info.value.status == 4 and info.value.function == "pc_step"
    assert isinstance(info.value, DomainError) and isinstance(info.value, SimulationError)
    again = pickle.loads(pickle.dumps(info.value))  # errors cross process boundaries unchanged
    assert type(again) is EngineArgumentError and again.status == 4 and str(again) == str(info.value)
    plant.set_newton(1e-16, 0.0, 1)
    with pytest.raises(NewtonError, match="Newton did not converge") as info:
        plant.step(q, v, 0.0, 5.0)
    assert info.value.status == 1 and isinstance(info.value, EngineError)
    with pytest.raises(EngineArgumentError, match="Newton settings"):
        plant.set_newton(-1.0, 0.0, 5)


def test_nothing_is_allocated_after_an_instance_exists(tmp_path):
    """Only the model and data life cycles (pc_model.c, pc_data.c) call the allocator; every other stage
    takes its scratch from the instance's arena."""
    cc = compiled.compiler()
    root = Path(compiled.__file__).parent / "csrc"
    allocators = {"malloc", "calloc", "realloc", "free"}
    users = set()
    for name in compiled.SOURCES:
        obj = tmp_path / (name + ".o")
        built = subprocess.run([cc, "-c", "-O0", "-std=c99", "-o", str(obj), str(root / name)], capture_output=True,
                               text=True)
        assert built.returncode == 0, built.stderr
        syms = subprocess.run(["nm", "-u", str(obj)], capture_output=True, text=True, check=True).stdout
        if allocators & {line.split()[-1] for line in syms.splitlines() if line.strip()}:
            users.add(name)
    assert users == {"pc_model.c", "pc_data.c"}


def test_the_arena_covers_the_deepest_call(system):
    """A prediction with every Jacobian and a simulated sample stay inside the arena (its high-water mark)."""
    plant = CompiledPlant(system)
    q, v = initial_state(system)
    plant.predict(q, v, 10.0, 0.1, 2, True, inputs=True)
    plant.simulate(q, v, 0.0, 0.1, 1, 3)
    plant.step_jacobian(q, v, 0.0, 0.1)
    assert 0 < plant.stats()["arena_peak"] <= system.nv * 10**6


def test_what_crosses_a_process_boundary(system):
    """A System and a constant model pickle (rebuilt by their constructors in the other process); an
    instance, which is a handle in this process's core, refuses with a message."""
    heavier = system.with_target_mass(8000.0)
    other = pickle.loads(pickle.dumps(heavier))
    assert other.target_mass == 8000.0
    np.testing.assert_array_equal(pack(other).doubles, pack(heavier).doubles)
    np.testing.assert_array_equal(pack(other).ints, pack(heavier).ints)
    plant = CompiledPlant(system)
    model = pickle.loads(pickle.dumps(plant.model))
    assert model.handle != plant.model.handle and model.param_names == plant.param_names
    q, v = initial_state(system)
    np.testing.assert_array_equal(CompiledPlant(model=model).step(q, v, 0.0, 0.1)[1], plant.step(q, v, 0.0, 0.1)[1])
    with pytest.raises(TypeError, match="cannot be pickled"):
        pickle.dumps(plant)
