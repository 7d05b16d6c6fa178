"""Terminal output: 80 columns for every command, -v logs the progress it promises, notes are not silent."""

import logging

import pytest

from postcapture.cli import main


def _lines(capsys):
    out, err = capsys.readouterr()
    return out, err, out.splitlines() + err.splitlines()


@pytest.mark.parametrize("argv", [
    ["modes"],
    ["simulate", "--duration", "2", "--panel-segments", "12"],
    ["panel", "calibrate", "--weights", "0.1"],
], ids=["modes", "simulate", "panel calibrate"])
def test_command_output_fits_80_columns(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv) == 0
    out, _, lines = _lines(capsys)
    assert out.strip()
    assert max(len(line) for line in lines) <= 80, [line for line in lines if len(line) > 80]


def test_verbose_logs_phases_and_each_case(capsys, caplog, tmp_path):
    caplog.set_level(logging.INFO, logger="postcapture.progress")
    code = main(["-v", "run", "--duration", "12", "--cases", "joint", "--no-crlb", "--no-plots",
                 "--workers", "1", "--out", str(tmp_path)])
    assert code == 0
    messages = [r.getMessage() for r in caplog.records if r.name == "postcapture.progress"]
    assert "run: truth simulation and sensors ..." in messages
    assert "joint: started" in messages
    assert any(m.startswith("joint: ") and " % after " in m and m.endswith(" left") for m in messages)
    assert any(m.startswith("  joint") and "done in" in m for m in messages)
    assert "run: filters: 1 cases in 1 process ..." in messages
    assert "Target mass at the end of the run" in capsys.readouterr().out


def test_an_fmu_plant_says_which_cases_it_skips(capsys, tmp_path, monkeypatch):
    import postcapture.studies.main_job as main_job
    from postcapture.cli import checks
    from postcapture.core.errors import FMIError

    def stop(*args, **kwargs):  # the FMU does not exist: stop where the job would start
        raise FMIError("no such file", fmu=str(tmp_path / "missing.fmu"), function="open")

    monkeypatch.setattr(checks, "run", lambda args: None)  # (the validation pass would refuse it first)
    monkeypatch.setattr(main_job, "run_main_job", stop)
    code = main(["run", "--plant", f"fmu:{tmp_path / 'missing.fmu'}", "--duration", "1", "--no-crlb",
                 "--out", str(tmp_path / "o")])
    assert code == 1  # the note comes first
    err = capsys.readouterr().err
    assert err.startswith("note: --plant fmu:")
    assert "skipped: ekf_stiff, mekf_stiff" in " ".join(err.split())
    note = err.split("postcapture: error:")[0]  # the error names a long temporary path; the note must fit
    assert max(len(line) for line in note.splitlines()) <= 80
