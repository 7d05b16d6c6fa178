"""A campaign's checkpoints prove what they hold: a swapped, damaged, foreign or stray file is set aside and its
run computed again, never counted (issue 18's reproducers)."""

import logging
import shutil

import numpy as np
import pytest

from postcapture.studies.checkpoints import SET_ASIDE, CheckpointError, load_run, settings_digest
from postcapture.studies.montecarlo import run_campaign

SETTINGS = dict(runs=3, dispersed=True, cases=("mekf_flexible",), duration=3.0, crlb=False, workers=0)


@pytest.fixture(scope="module")
def reference(envisat):
    """The campaign computed in memory, with no checkpoint involved: what every resumed campaign must equal."""
    return run_campaign(envisat, **SETTINGS)


@pytest.fixture
def saved(envisat, tmp_path):
    """A finished campaign folder (its checkpoints)."""
    out = tmp_path / "c"
    run_campaign(envisat, out=out, **SETTINGS)
    return out


def _equal(a, b):
    assert [r["run"] for r in a.runs] == [r["run"] for r in b.runs]
    for ra, rb in zip(a.runs, b.runs):
        np.testing.assert_array_equal(ra["truth"], rb["truth"])
        for key in ("mass_error", "attitude_error", "attitude_nees"):
            np.testing.assert_array_equal(ra["cases"]["mekf_flexible"][key], rb["cases"]["mekf_flexible"][key])


def test_a_run_swapped_for_another_is_not_counted_twice(envisat, saved, reference, caplog):
    runs = saved / "runs"
    shutil.copyfile(runs / "run_00001.npz", runs / "run_00002.npz")  # run 2's file now holds run 1
    with caplog.at_level(logging.WARNING, logger="postcapture"):
        resumed = run_campaign(envisat, out=saved, **SETTINGS)
    assert resumed.resumed == 2  # runs 0 and 1; run 2 was computed again
    _equal(resumed, reference)
    truths = [tuple(r["truth"]) for r in resumed.runs]
    assert len(set(truths)) == 3  # three different drawn truths: no run twice
    lines = [r.getMessage() for r in caplog.records if "run_00002.npz" in r.getMessage()]
    assert len(lines) == 1 and "holds run 1, not run 2" in lines[0], lines
    assert (runs / SET_ASIDE / "run_00002.npz").exists()
    # the recomputed checkpoint is valid again
    assert load_run(runs / "run_00002.npz", run=2, digest=settings_digest(resumed.settings))["run"] == 2


@pytest.mark.parametrize("damage", ["empty", "truncated", "random", "flipped_byte", "stray_copy", "foreign"])
def test_a_bad_or_foreign_file_is_set_aside_and_recomputed(envisat, saved, reference, damage, caplog, tmp_path):
    runs = saved / "runs"
    victim = runs / "run_00001.npz"
    data = victim.read_bytes()
    name = victim.name
    if damage == "empty":
        victim.write_bytes(b"")
    elif damage == "truncated":
        victim.write_bytes(data[: len(data) // 2])
    elif damage == "random":
        victim.write_bytes(np.random.default_rng(5).bytes(len(data)))
    elif damage == "flipped_byte":  # a change that leaves the zip readable: in an array's bytes
        arrays = dict(np.load(victim))
        arrays["truth"] = arrays["truth"].copy()
        arrays["truth"][0] += 1.0
        with open(victim, "wb") as f:
            np.savez(f, **arrays)
    elif damage == "stray_copy":
        name = "run_00001 (copy).npz"
        shutil.copyfile(victim, runs / name)
    elif damage == "foreign":  # the same run of a campaign with other settings
        other = tmp_path / "other"
        run_campaign(envisat, out=other, **{**SETTINGS, "duration": 2.0})
        shutil.copyfile(other / "runs" / "run_00001.npz", victim)
    with caplog.at_level(logging.WARNING, logger="postcapture"):
        resumed = run_campaign(envisat, out=saved, **SETTINGS)
    _equal(resumed, reference)
    assert resumed.resumed == (3 if damage == "stray_copy" else 2)
    lines = [r.getMessage() for r in caplog.records if name in r.getMessage()]
    assert len(lines) == 1 and "moved to" in lines[0], lines
    assert (runs / SET_ASIDE / name).exists() and not (runs / name).exists() or name == "run_00001.npz"


def test_the_cli_sets_bad_files_aside_with_one_line_each(saved):
    import subprocess
    import sys
    from pathlib import Path

    runs = saved / "runs"
    (runs / "run_00000.npz").write_bytes(b"PK\x03\x04 not really")
    shutil.copyfile(runs / "run_00002.npz", runs / "run_00002 (copy).npz")
    done = subprocess.run([str(Path(sys.executable).parent / "postcapture"), "campaign", "--runs", "3", "--dispersed",
                           "--duration", "3", "--cases", "mekf_flexible", "--workers", "0", "--no-crlb", "--no-plots",
                           "--out", str(saved)], capture_output=True, text=True, timeout=300)
    err = done.stderr
    assert done.returncode == 0, err
    assert "Traceback" not in err and "internal error" not in err
    assert sum("run_00000.npz" in line and "moved to" in line for line in err.splitlines()) == 1, err
    assert sum("run_00002 (copy).npz" in line and "moved to" in line for line in err.splitlines()) == 1, err


def test_a_checkpoint_checks_its_run_and_campaign(saved):
    from postcapture.studies.checkpoints import _read

    header, _ = _read(saved / "runs" / "run_00001.npz")
    digest = header["settings_sha256"]
    assert load_run(saved / "runs" / "run_00001.npz", run=1, digest=digest)["run"] == 1
    with pytest.raises(CheckpointError, match="holds run 1, not run 0"):
        load_run(saved / "runs" / "run_00001.npz", run=0, digest=digest)
    with pytest.raises(CheckpointError, match="other settings"):
        load_run(saved / "runs" / "run_00001.npz", run=1, digest="0" * 64)
