"""Build folders a kill left behind are removed by the next build (issue 18: ``fmu export`` killed with SIGKILL
left ``/tmp/postcapture_fmu_*`` for good)."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from postcapture.io.scratch import remove_stale_scratch, scratch_folder

EXE = str(Path(sys.executable).parent / "postcapture")


def test_a_killed_builds_folder_goes_at_the_next_build(tmp_path):
    # a real process that makes its scratch folder and is killed while it holds it
    code = ("import sys, time; from postcapture.io.scratch import scratch_folder\n"
            f"with scratch_folder('pc_test', {str(tmp_path)!r}) as p:\n"
            "    (p / 'obj.o').write_text('x'); print(p, flush=True); time.sleep(600)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    left = Path(proc.stdout.readline().strip())
    assert left.is_dir()
    assert remove_stale_scratch("pc_test", tmp_path) == 0  # its process still runs: kept
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert left.is_dir()  # nothing ran to remove it
    with scratch_folder("pc_test", tmp_path) as fresh:
        assert fresh.is_dir() and not left.exists()
        assert [p.name for p in tmp_path.iterdir()] == [fresh.name]
    assert list(tmp_path.iterdir()) == []


def test_fmu_export_killed_leaves_nothing_after_the_next_export(tmp_path):
    env = dict(os.environ, TMPDIR=str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    proc = subprocess.Popen([EXE, "fmu", "export", "--variant", "rigid", "--no-step-jacobian", "--no-directional",
                             "-o", str(tmp_path / "a.fmu")], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 240
    while not any(p.name.startswith("postcapture_fmu-") for p in (tmp_path / "tmp").iterdir()):
        assert proc.poll() is None and time.monotonic() < deadline, proc.stderr.read()
        time.sleep(0.01)
    proc.kill()
    proc.wait()
    assert any(p.name.startswith("postcapture_fmu-") for p in (tmp_path / "tmp").iterdir())
    done = subprocess.run([EXE, "fmu", "export", "--variant", "rigid", "--no-step-jacobian", "--no-directional",
                           "-o", str(tmp_path / "b.fmu")], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert not any(p.name.startswith("postcapture_fmu") for p in (tmp_path / "tmp").iterdir())
