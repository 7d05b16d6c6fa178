"""What a user sees in an 80-column terminal: progress during the filters, and nothing wider than 80 columns.

``postcapture run`` runs as the installed script in a pseudo-terminal of 80 x 24, as a user's shell
would run it; everything it writes (stdout and stderr share the terminal) is read back, the cursor
controls are removed, and the text is cut at every carriage return and newline into what the
terminal draws on one line.
"""

import fcntl
import os
import pty
import re
import select
import shutil
import struct
import subprocess
import sys
import termios
import time
from pathlib import Path

import pytest

CSI = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")
CASES = ("ekf_flexible", "joint_flexible")


def _script() -> str:
    path = Path(sys.executable).with_name("postcapture")
    return str(path) if path.exists() else shutil.which("postcapture")


def _run_in_pty(argv, *, columns=80, rows=24, timeout=120.0) -> tuple[int, str]:
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", rows, columns, 0, 0))
    env = {**os.environ, "COLUMNS": str(columns), "LINES": str(rows), "TERM": "xterm"}
    proc = subprocess.Popen(argv, stdin=slave, stdout=slave, stderr=slave, env=env, close_fds=True)
    os.close(slave)
    chunks = []
    deadline = time.monotonic() + timeout
    try:
        while time.monotonic() < deadline:
            ready, _, _ = select.select([master], [], [], 0.2)
            if ready:
                try:
                    data = os.read(master, 65536)
                except OSError:  # EIO: the child closed the terminal
                    break
                if not data:
                    break
                chunks.append(data)
            elif proc.poll() is not None:
                break
        code = proc.wait(timeout=max(1.0, deadline - time.monotonic()))
    finally:
        if proc.poll() is None:
            proc.kill()
        os.close(master)
    return code, b"".join(chunks).decode("utf-8", errors="replace")


def _screen_lines(text: str) -> list[str]:
    """Every piece of text the terminal draws between line starts (\\r, \\n), control sequences removed."""
    return [piece for piece in re.split(r"[\r\n]", CSI.sub("", text))]


@pytest.fixture(scope="module")
def run_in_terminal(tmp_path_factory):
    out = tmp_path_factory.mktemp("pty_run")
    argv = [_script(), "run", "--duration", "20", "--cases", ",".join(CASES), "--out", str(out)]
    code, text = _run_in_pty(argv)
    return code, text, out


def test_progress_shows_during_the_filters(run_in_terminal):
    code, text, _ = run_in_terminal
    assert code == 0, text[-2000:]
    lines = _screen_lines(text)
    # per-case bars: "  ekf_flexible   37%|███   | 00:01<00:02" with a percentage strictly between 0 and 100
    seen = {case: set() for case in CASES}
    for line in lines:
        m = re.match(r"\s+(\w+)\s+(\d+)%\|", line)
        if m and m.group(1) in seen:
            seen[m.group(1)].add(int(m.group(2)))
    for case in CASES:
        assert any(0 < p < 100 for p in seen[case]), f"no intermediate progress for {case}: {sorted(seen[case])}"
    # the bars carry the time remaining, and the phases are named
    assert any(re.search(r"\d\d:\d\d<\d\d:\d\d", line) for line in lines)
    assert any(line.startswith("run: filters: 2 cases") for line in lines)
    # the table comes after the filters have reported
    first_table = text.index("Target mass at the end of the run")
    assert text.rfind("ekf_flexible", 0, first_table) > 0


def test_every_line_fits_80_columns(run_in_terminal):
    code, text, out = run_in_terminal
    assert code == 0
    lines = _screen_lines(text)
    too_wide = [line for line in lines if len(line.rstrip()) > 80]
    assert not too_wide, too_wide[:5]
    # the table and the closing lines are there (not an empty run), and the table file too
    assert any(line.startswith("Attitude (steady") for line in lines)
    assert any(line.startswith("written to ") for line in lines)
    table = (out / "table.txt").read_text().splitlines()
    assert table and max(len(line) for line in table) <= 80


def test_not_a_terminal_means_no_bars(tmp_path):
    """Piped, the same command writes only its result: no bars, no phase lines, on either stream."""
    argv = [_script(), "run", "--duration", "3", "--cases", "joint_flexible", "--no-crlb", "--no-plots",
            "--workers", "1", "--out", str(tmp_path)]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert "%|" not in proc.stdout and "Target mass at the end of the run" in proc.stdout
