"""Ctrl-C at any moment of a command's life: one line, status 130, never a traceback (issue 18).

A timed ``timeout -s INT 0.15 postcapture --version`` lands wherever the machine's speed puts it. Here the
interrupt follows an event instead: a ``sitecustomize`` module on the command's path sends SIGINT to the
process as it starts importing a chosen module (startup, the parser, the scenario loader, numpy during
the work), or as the interpreter exits after the command has finished.
"""

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

EXE = str(Path(sys.executable).parent / "postcapture")

HOOK = r'''
import atexit, os, signal, sys

_TARGET = os.environ.get("PC_TEST_INTERRUPT_AT", "")


class _InterruptOnImport:
    def find_spec(self, name, path=None, target=None):
        if name == _TARGET:
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None


if _TARGET == "exit":
    atexit.register(lambda: os.kill(os.getpid(), signal.SIGINT))
elif _TARGET:
    sys.meta_path.insert(0, _InterruptOnImport())
'''


@pytest.fixture(scope="module")
def hook_dir(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hook")
    (folder / "sitecustomize.py").write_text(HOOK)
    return folder


def _default_sigint():
    signal.signal(signal.SIGINT, signal.SIG_DFL)  # a test run in the background inherits SIGINT ignored


@pytest.mark.parametrize(("argv", "where"), [
    (["--version"], "postcapture.cli.main"),  # the command line's modules are being imported
    (["--version"], "argparse"),
    (["--version"], "exit"),  # after the command has printed its answer
    (["modes", "--count", "1"], "postcapture.config.loader"),  # the scenario is being loaded
    (["modes", "--count", "1"], "scipy.linalg"),  # the work has started
    (["modes", "--count", "1"], "exit"),
])
def test_ctrl_c_at_any_moment_gives_one_line(hook_dir, tmp_path, argv, where):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(hook_dir), os.environ.get("PYTHONPATH", "")]),
               PC_TEST_INTERRUPT_AT=where, MPLBACKEND="Agg")
    done = subprocess.run([EXE, *argv], capture_output=True, text=True, timeout=300, env=env, cwd=tmp_path,
                          preexec_fn=_default_sigint)
    assert "Traceback" not in done.stderr and "KeyboardInterrupt" not in done.stderr, done.stderr
    if where == "exit":  # the command finished; the interrupt only ends the interpreter's shutdown
        assert done.returncode in (0, 130) and done.stdout, (done.returncode, done.stderr)
    else:
        assert done.returncode == 130, (done.returncode, done.stderr)
        assert done.stderr.strip().splitlines()[-1] == "postcapture: interrupted", done.stderr
