"""One file written atomically; output paths that are not regular files are refused and left untouched."""

import os
import socket
import stat
import subprocess
import sys

import pytest

from postcapture.core.errors import OutputPathError
from postcapture.io import check_output_file, check_output_folder, safe_stem, write_atomic
from postcapture.io.atomic import TAG, remove_stale


def _write(text):
    return lambda p: open(p, "w").write(text)


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_writes_and_replaces_a_regular_file(tmp_path):
    target = tmp_path / "sub" / "out.txt"
    assert write_atomic(target, _write("one")) == target
    write_atomic(target, _write("two"))
    assert target.read_text() == "two"
    assert sorted(os.listdir(target.parent)) == ["out.txt"]
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~umask


def test_character_device_is_refused_and_kept(tmp_path):
    st = os.stat("/dev/null")
    with pytest.raises(OutputPathError, match="/dev/null: a character device, not a regular file"):
        write_atomic("/dev/null", _write("x"))
    assert os.stat("/dev/null").st_rdev == st.st_rdev and stat.S_ISCHR(os.stat("/dev/null").st_mode)
    with pytest.raises(OutputPathError, match="a character device"):
        check_output_file("/dev/null")


def test_fifo_socket_folder_and_link_are_refused(tmp_path):
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    sock_path = tmp_path / "sock"
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(sock_path))
    real = tmp_path / "real.txt"
    real.write_text("keep")
    link = tmp_path / "link.txt"
    link.symlink_to(real)
    cases = {fifo: "a FIFO", sock_path: "a socket", tmp_path: "a folder", link: "a symbolic link"}
    try:
        for path, kind in cases.items():
            with pytest.raises(OutputPathError, match=f"{kind}.*, not a regular file") as err:
                write_atomic(path, _write("x"))
            assert err.value.filename == str(path)
    finally:
        sock.close()
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and os.path.islink(link) and real.read_text() == "keep"
    assert not [p for p in os.listdir(tmp_path) if TAG in p]


@pytest.mark.parametrize("bad", ["", "   ", "a\x00b"])
def test_empty_or_nul_paths(bad):
    with pytest.raises(OutputPathError, match="an empty file path|a NUL character in a file path"):
        check_output_file(bad)
    with pytest.raises(OutputPathError, match="an empty folder path|a NUL character in a folder path"):
        check_output_folder(bad)


def test_parent_that_is_a_file(tmp_path):
    (tmp_path / "f").write_text("")
    with pytest.raises(OutputPathError, match=r"x.nc: .*/f is a regular file, not a folder"):
        check_output_file(tmp_path / "f" / "x.nc")
    with pytest.raises(OutputPathError, match="a regular file, not a folder"):
        check_output_folder(tmp_path / "f")


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_unwritable_parent(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir(mode=0o555)
    with pytest.raises(OutputPathError, match="no permission to create files"):
        check_output_file(ro / "x.nc")


def test_failed_writer_and_interrupt_leave_no_temporary(tmp_path):
    target = tmp_path / "keep.txt"
    target.write_text("old")

    def interrupted(p):
        open(p, "w").write("half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_atomic(target, interrupted)
    with pytest.raises(OutputPathError, match="write failed: No space left on device"):
        write_atomic(target, lambda p: (_ for _ in ()).throw(OSError(28, "No space left on device")))
    with pytest.raises(ZeroDivisionError):  # a bug in a writer is not dressed up as a path error
        write_atomic(target, lambda p: 1 / 0)
    assert target.read_text() == "old" and os.listdir(tmp_path) == ["keep.txt"]


def test_temporaries_of_killed_writers_are_removed_by_the_next_write(tmp_path):
    target = tmp_path / "out.nc"
    stale = tmp_path / f".out.nc{TAG}{_dead_pid()}-abcd.tmp"
    stale.write_text("left by a kill")
    live = tmp_path / f".out.nc{TAG}{os.getppid()}-abcd.tmp"  # a running process's: kept
    live.write_text("in use")
    other = tmp_path / ".other.postcapture-1-x.tmp"
    other.write_text("another target's")
    write_atomic(target, _write("new"))
    assert not stale.exists() and live.exists() and other.exists()
    assert remove_stale(tmp_path, "out.nc") == 0


def test_safe_stem():
    assert safe_stem("envisat") == "envisat"
    assert safe_stem("../../etc/passwd") == "_.._etc_passwd"
    assert safe_stem("a b/c\u00e9") == "a_b_c_"
    assert safe_stem("...") == "unnamed" and safe_stem("") == "unnamed"
    assert len(safe_stem("x" * 1000)) == 100
