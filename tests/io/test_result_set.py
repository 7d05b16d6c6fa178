"""A folder of results is written as one set: the old complete set or the new one, never a mix."""

import json
import logging
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from postcapture.core.errors import OutputPathError
from postcapture.io import MANIFEST, ResultSet
from postcapture.io import result_set as rs_module
from postcapture.io.atomic import TAG

OWNED = ("a.txt", "b.txt", "fig*.png")


def _write_set(folder, generation, names=("a.txt", "b.txt")):
    with ResultSet(folder, owned=OWNED, kind="test") as rs:
        for name in names:
            rs.write(name, lambda p: Path(p).write_text(str(generation)))
    return rs


def _temporaries(parent):
    return [p for p in os.listdir(parent) if TAG in p]


def _dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_new_folder_then_replaced_set_with_foreign_entries_kept(tmp_path):
    out = tmp_path / "res"
    _write_set(out, 1, ("a.txt", "b.txt", "fig1.png"))
    assert json.loads((out / MANIFEST).read_text())["files"] == ["a.txt", "b.txt", "fig1.png"]
    (out / "notes.md").write_text("mine")  # a user's file
    (out / "panel").mkdir()  # another command's output
    (out / "panel" / "calibration.json").write_text("{}")
    (out / "link").symlink_to("notes.md")
    inode = (out / "notes.md").stat().st_ino
    _write_set(out, 2, ("a.txt", "b.txt"))
    assert (out / "a.txt").read_text() == "2" and (out / "b.txt").read_text() == "2"
    assert not (out / "fig1.png").exists()  # part of the old set only
    assert (out / "notes.md").read_text() == "mine" and (out / "notes.md").stat().st_ino == inode  # hard link
    assert (out / "panel" / "calibration.json").read_text() == "{}" and os.readlink(out / "link") == "notes.md"
    assert _temporaries(tmp_path) == [] and _temporaries(out) == []


def test_folder_without_manifest_owned_patterns_decide(tmp_path):
    out = tmp_path / "res"
    out.mkdir()
    for name in ("a.txt", "fig9.png", "keep.csv"):
        (out / name).write_text("old")
    _write_set(out, 3, ("a.txt",))
    assert sorted(os.listdir(out)) == sorted([MANIFEST, "a.txt", "keep.csv"])


def test_failure_or_interrupt_inside_leaves_the_old_set(tmp_path):
    out = tmp_path / "res"
    _write_set(out, 1)
    for exc in (KeyboardInterrupt, OSError(28, "No space left on device"), ValueError("bug")):
        with pytest.raises((KeyboardInterrupt, OSError, ValueError)):
            with ResultSet(out, owned=OWNED) as rs:
                rs.write("a.txt", lambda p: Path(p).write_text("partial"))
                raise exc
        assert (out / "a.txt").read_text() == "1" and (out / "b.txt").read_text() == "1"
        assert _temporaries(tmp_path) == []


def test_writer_failure_is_a_path_error(tmp_path):
    out = tmp_path / "res"
    _write_set(out, 1)

    def full(p):
        Path(p).write_text("x")
        raise RuntimeError("NetCDF: HDF error")

    with pytest.raises(OutputPathError, match=r"res/b.txt: write failed: NetCDF: HDF error"):
        with ResultSet(out, owned=OWNED) as rs:
            rs.write("a.txt", lambda p: Path(p).write_text("2"))
            rs.write("b.txt", full)
    assert (out / "a.txt").read_text() == "1" and _temporaries(tmp_path) == []


@pytest.mark.parametrize("bad", ["../x", "a/b", "", ".", MANIFEST, f"x{TAG}1"])
def test_names_are_plain(tmp_path, bad):
    with pytest.raises(ValueError, match="expected one plain name"):
        with ResultSet(tmp_path / "res") as rs:
            rs.write(bad, lambda p: None)


def test_not_a_folder_is_refused_and_kept(tmp_path):
    f = tmp_path / "res"
    f.write_text("a file")
    with pytest.raises(OutputPathError, match="res: a regular file, not a folder"):
        ResultSet(f)
    real = tmp_path / "real"
    real.mkdir()
    link = tmp_path / "link"
    link.symlink_to(real)
    with pytest.raises(OutputPathError, match="a symbolic link, not a folder"):
        ResultSet(link)
    assert f.read_text() == "a file" and link.is_symlink()


def test_two_rename_fallback_and_recovery_after_a_crash_between(tmp_path, monkeypatch):
    out = tmp_path / "res"
    _write_set(out, 1)
    monkeypatch.setattr(rs_module, "_exchange", lambda a, b: False)  # a system without renameat2
    _write_set(out, 2)
    assert (out / "a.txt").read_text() == "2" and _temporaries(tmp_path) == []
    # a writer killed after moving the old set aside and before moving the new one in:
    os.rename(out, tmp_path / f".res{TAG}{_dead_pid()}-dead.old")
    rs = ResultSet(out, owned=OWNED)
    with rs:
        assert (out / "a.txt").read_text() == "2"  # restored on entry, before anything else
        rs.write("a.txt", lambda p: Path(p).write_text("3"))
    assert (out / "a.txt").read_text() == "3" and _temporaries(tmp_path) == []


def test_stale_temporaries_of_a_killed_writer_are_removed(tmp_path):
    out = tmp_path / "res"
    stale = tmp_path / f".res{TAG}{_dead_pid()}-dead"
    stale.mkdir()
    (stale / "a.txt").write_text("half")
    _write_set(out, 1)
    assert not stale.exists()


def test_working_folder_is_updated_in_place_with_a_warning(tmp_path, monkeypatch, caplog):
    out = tmp_path / "res"
    _write_set(out, 1, ("a.txt", "b.txt", "fig1.png"))
    (out / "mine.txt").write_text("mine")
    monkeypatch.chdir(out)
    with caplog.at_level(logging.WARNING):
        rs = _write_set(".", 2, ("a.txt", "b.txt"))
    assert rs.in_place and "replaced one by one" in caplog.text
    assert sorted(os.listdir(out)) == sorted([MANIFEST, "a.txt", "b.txt", "mine.txt"])
    assert (out / "a.txt").read_text() == "2"


def test_a_reader_holding_the_folder_sees_one_generation(tmp_path):
    """Swaps under a reader that opens the folder once and its files relative to it: never a mix.

    (A reader still holding the old folder may find its files going as it is removed: it reads again.)
    """
    out = tmp_path / "res"
    _write_set(out, 0)
    stop = threading.Event()
    seen, missing = set(), []

    def read(name, fd):
        f = os.open(name, os.O_RDONLY, dir_fd=fd)
        try:
            return os.read(f, 64)
        finally:
            os.close(f)

    def reader():
        while not stop.is_set():
            try:
                fd = os.open(out, os.O_RDONLY | os.O_DIRECTORY)
            except FileNotFoundError:
                missing.append(1)
                continue
            try:
                seen.add((read("a.txt", fd), read("b.txt", fd)))
            except FileNotFoundError:
                pass  # the folder held was the old set, being removed after the swap: read again
            finally:
                os.close(fd)

    thread = threading.Thread(target=reader)
    thread.start()
    try:
        for generation in range(1, 60):
            _write_set(out, generation)
    finally:
        stop.set()
        thread.join()
    assert all(a == b for a, b in seen), [s for s in seen if s[0] != s[1]][:3]
    assert len(seen) > 1
    if rs_module._exchange(tmp_path / "res", tmp_path / "res"):  # renameat2 available: never a missing folder
        assert missing == []
