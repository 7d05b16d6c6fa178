"""The check of an output path creates a file to find out whether it can (``/proc``, read-only or full file
systems); that file must not look like the target's temporary, and must not stay."""

import os

from postcapture.io import check_output_file, check_output_folder
from postcapture.io.atomic import TAG


def test_the_probe_is_no_temporary_of_the_target_and_leaves_nothing(tmp_path, monkeypatch):
    created = []
    real_open = os.open

    def spy(path, flags, *args, **kwargs):
        if flags & os.O_CREAT:
            created.append(os.path.basename(path))
        return real_open(path, flags, *args, **kwargs)

    monkeypatch.setattr(os, "open", spy)
    check_output_folder(tmp_path / "res")
    check_output_file(tmp_path / "x.nc")
    assert len(created) == 2  # one probe per check
    assert not any(name.startswith((f".res{TAG}", f".x.nc{TAG}")) for name in created), created
    assert list(tmp_path.iterdir()) == []


def test_a_probe_a_kill_left_is_removed(tmp_path):
    import subprocess
    import sys

    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    left = tmp_path / f".postcapture-probe-{int(dead.stdout)}-0badcafe"
    left.write_text("")
    check_output_file(tmp_path / "x.nc")
    assert list(tmp_path.iterdir()) == []
