"""Faults around ``postcapture run``: a kill while writing, a full file system, Ctrl-C and SIGTERM.

The results folder must hold the previous complete set after any of them, no temporary may outlive a
normal or interrupted exit (a killed writer's are removed by the next write), and an interrupt stops
the worker processes at once with one line and no traceback.

The full file system is simulated without privileges: a small preloaded library makes ``write``,
``pwrite`` and ``writev`` fail with ENOSPC once the files under one folder have received a byte budget
(compiled here with the system C compiler, as the FMI tests build their FMUs).
"""

import hashlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from postcapture.studies.results import RUN_FILES
from postcapture.io import ResultSet
from postcapture.io.atomic import TAG

EXE = str(Path(sys.executable).parent / "postcapture")
QUICK = ["run", "--duration", "2", "--cases", "ekf_flexible", "--no-crlb", "--workers", "1"]

ENOSPC_SHIM = r"""
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/uio.h>
#include <unistd.h>

static long long used = 0;

static int refuse(int fd, size_t n) {
    const char *prefix = getenv("FULL_PREFIX"), *budget = getenv("FULL_BUDGET");
    char link[64], path[4096];
    ssize_t len;
    if (!prefix || !budget) return 0;
    snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
    len = readlink(link, path, sizeof path - 1);
    if (len <= 0) return 0;
    path[len] = 0;
    if (strncmp(path, prefix, strlen(prefix)) != 0) return 0;
    if (used + (long long)n > atoll(budget)) { errno = ENOSPC; return 1; }
    used += n;
    return 0;
}
ssize_t write(int fd, const void *buf, size_t n) {
    static ssize_t (*real)(int, const void *, size_t);
    if (!real) real = dlsym(RTLD_NEXT, "write");
    return refuse(fd, n) ? -1 : real(fd, buf, n);
}
ssize_t pwrite(int fd, const void *buf, size_t n, off_t off) {
    static ssize_t (*real)(int, const void *, size_t, off_t);
    if (!real) real = dlsym(RTLD_NEXT, "pwrite");
    return refuse(fd, n) ? -1 : real(fd, buf, n, off);
}
ssize_t pwrite64(int fd, const void *buf, size_t n, off_t off) {
    static ssize_t (*real)(int, const void *, size_t, off_t);
    if (!real) real = dlsym(RTLD_NEXT, "pwrite64");
    return refuse(fd, n) ? -1 : real(fd, buf, n, off);
}
ssize_t writev(int fd, const struct iovec *iov, int cnt) {
    static ssize_t (*real)(int, const struct iovec *, int);
    size_t n = 0;
    int i;
    if (!real) real = dlsym(RTLD_NEXT, "writev");
    for (i = 0; i < cnt; i++) n += iov[i].iov_len;
    return refuse(fd, n) ? -1 : real(fd, iov, cnt);
}
"""


def _snapshot(folder: Path) -> dict:
    """Name -> SHA-256 of every file in the folder (the set, as a reader would see it)."""
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(folder.iterdir()) if p.is_file()}


def _temporaries(folder: Path) -> list[str]:
    return [p.name for p in folder.rglob("*") if TAG in p.name]


def _ctrl_c_reaches_the_command() -> None:
    """Popen's preexec_fn: SIGINT back to its default in the command (a test run started in the background
    by a non-interactive shell inherits SIGINT ignored, and Python then keeps ignoring it, as a background
    job should)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _env(**extra):
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", MPLBACKEND="Agg")
    env.update(extra)
    return env


@pytest.fixture(scope="module")
def previous_set(tmp_path_factory):
    """A complete results folder of an earlier run, and its snapshot."""
    parent = tmp_path_factory.mktemp("faults")
    out = parent / "res"
    done = subprocess.run([EXE, *QUICK, "--out", str(out)], capture_output=True, text=True, timeout=300,
                          env=_env())
    assert done.returncode == 0, done.stderr
    (out / "my_notes.txt").write_text("not ours: must survive every run")
    return out, _snapshot(out)


def _fresh_copy(previous_set, tmp_path) -> tuple[Path, dict]:
    import shutil

    src, snap = previous_set
    out = tmp_path / "res"
    shutil.copytree(src, out)
    return out, snap


def _children(pid: int) -> list[int]:
    kids = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                stat_line = Path(f"/proc/{entry}/stat").read_text()
            except OSError:
                continue
            if int(stat_line.rsplit(")", 1)[1].split()[1]) == pid:
                kids.append(int(entry))
    return kids


@pytest.mark.parametrize("delay", [0.0, 0.15])
def test_sigkill_while_writing_leaves_the_previous_set(previous_set, tmp_path, delay):
    out, snap = _fresh_copy(previous_set, tmp_path)
    proc = subprocess.Popen([EXE, *QUICK, "--out", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            env=_env())
    deadline = time.monotonic() + 240
    while not any(name.startswith(f".res{TAG}") for name in os.listdir(tmp_path)):  # it started writing
        assert proc.poll() is None, "the run ended before it wrote anything"
        assert time.monotonic() < deadline
        time.sleep(0.002)
    time.sleep(delay)
    proc.kill()
    proc.wait()
    assert _snapshot(out) == snap  # the previous complete set, untouched
    assert _temporaries(tmp_path), "the kill was meant to land while the set was being written"
    with ResultSet(out, owned=RUN_FILES) as rs:  # the next write of a set there (a run's, here an empty one)
        assert _temporaries(tmp_path) == [rs._tmp.name]  # the killed writer's folder is gone
    assert _temporaries(tmp_path) == []
    assert (out / "my_notes.txt").read_text() == "not ours: must survive every run"


@pytest.fixture(scope="module")
def enospc_shim(tmp_path_factory):
    folder = tmp_path_factory.mktemp("shim")
    (folder / "full.c").write_text(ENOSPC_SHIM)
    subprocess.run(["gcc", "-shared", "-fPIC", "-O1", "-o", str(folder / "full.so"), str(folder / "full.c"), "-ldl"],
                   check=True)
    return folder / "full.so"


@pytest.mark.parametrize("fraction", [0.02, 0.6])
def test_full_file_system_leaves_the_previous_set(previous_set, tmp_path, enospc_shim, fraction):
    out, snap = _fresh_copy(previous_set, tmp_path)
    budget = int(fraction * sum(p.stat().st_size for p in out.iterdir()))
    done = subprocess.run([EXE, *QUICK, "--out", str(out)], capture_output=True, text=True, timeout=300,
                          env=_env(LD_PRELOAD=str(enospc_shim), FULL_PREFIX=str(tmp_path), FULL_BUDGET=str(budget)))
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr and done.stderr.count("postcapture: error:") == 1, done.stderr
    assert "write failed" in done.stderr and ("No space left on device" in done.stderr or "HDF error" in done.stderr)
    assert _snapshot(out) == snap
    assert _temporaries(tmp_path) == []  # removed on the error path


@pytest.mark.parametrize(("how", "status", "line"), [
    ("group", 130, "postcapture: interrupted"),  # Ctrl-C in a terminal: the whole process group
    ("parent", 130, "postcapture: interrupted"),  # SIGINT to the parent alone
    ("term", 143, "postcapture: terminated"),
])
def test_interrupt_stops_the_workers_at_once(tmp_path, how, status, line):
    proc = subprocess.Popen([EXE, "run", "--duration", "60", "--no-plots", "--out", str(tmp_path / "r")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            env=_env(), preexec_fn=_ctrl_c_reaches_the_command)
    deadline = time.monotonic() + 240
    while len(kids := _children(proc.pid)) < 2:  # the case pool is running
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read() if proc.poll() else ""
        time.sleep(0.05)
    time.sleep(1.0)
    t0 = time.monotonic()
    if how == "group":
        os.killpg(proc.pid, signal.SIGINT)
    else:
        os.kill(proc.pid, signal.SIGINT if how == "parent" else signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    elapsed = time.monotonic() - t0
    assert proc.returncode == status, err
    assert err.strip() == line and out == ""  # one line, no worker traceback
    assert elapsed < 5.0, elapsed  # the workers were stopped, not waited for
    assert not [k for k in kids if Path(f"/proc/{k}").exists() and "Z" not in Path(f"/proc/{k}/stat").read_text()]
    assert not (tmp_path / "r").exists() and _temporaries(tmp_path) == []


def test_interrupted_campaign_workers_print_no_traceback(tmp_path):
    """The Dask workers of a local cluster leave Ctrl-C to the parent as the case pool's do.

    The interrupt follows an event the test observes, the first run's checkpoint on disk, never a fixed
    sleep: on a quiet machine a short campaign used to end before a timed interrupt arrived, and on a
    loaded one the interrupt came before the workers were up. The campaign has far more runs than can
    finish between that event and the interrupt.
    """
    out_dir = tmp_path / "c"
    proc = subprocess.Popen([EXE, "campaign", "--runs", "400", "--duration", "30", "--cases", "ekf_flexible",
                             "--no-plots", "--workers", "2", "--out", str(out_dir)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True, env=_env(),
                            preexec_fn=_ctrl_c_reaches_the_command)
    deadline = time.monotonic() + 300
    while not list((out_dir / "runs").glob("run_*.npz")):  # a run has finished: the workers are busy
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read() if proc.poll() else ""
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and out == "", err
    assert "Traceback" not in err and err.strip().splitlines()[-1] == "postcapture: interrupted", err


def test_a_reader_that_goes_away_is_no_error(tmp_path):
    """``postcapture modes | head -0``: the closed pipe ends the command quietly (status 141, as SIGPIPE
    would), with no message and no traceback on stderr."""
    proc = subprocess.Popen([EXE, "modes"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=tmp_path)
    proc.stdout.close()  # before the command has printed anything (it takes a second to import)
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141, err
    assert err == "", err
