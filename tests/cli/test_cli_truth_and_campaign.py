"""The command line of studies: a truth apart from the filters, and campaigns."""

import json

import pytest
import tomli_w

from postcapture.cli import main


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_run_with_a_drawn_truth_records_it(capsys, tmp_path):
    code, out, err = run(capsys, "run", "--truth-draw", "11", "--duration", "3", "--cases", "mekf_flexible",
                         "--workers", "1", "--no-crlb", "--no-plots", "--json", "--out", str(tmp_path / "r"))
    assert code == 0, err
    truth = json.loads(out)["truth"]
    assert truth["source"] == "draw 11" and truth["panel_segments"] == [20, 20]
    saved = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert saved["truth"] == truth


def test_run_with_a_truth_scenario(capsys, tmp_path, envisat_dict):
    envisat_dict["arm"]["joints"][1]["stiffness"] = 8.0e4
    path = tmp_path / "soft_arm.toml"
    path.write_bytes(tomli_w.dumps(envisat_dict).encode())
    code, out, err = run(capsys, "run", "--truth-scenario", str(path), "--duration", "3", "--cases", "mekf_flexible",
                         "--workers", "1", "--no-crlb", "--no-plots", "--json", "--out", str(tmp_path / "r"))
    assert code == 0, err
    truth = json.loads(out)["truth"]
    assert truth["arm.stiffness_scale"] == (6 + 0.8) / 7  # one joint of seven at 80 %


def test_truth_options_are_checked_before_any_simulation(capsys, tmp_path, envisat_dict):
    del envisat_dict["target"]["panels"]
    path = tmp_path / "no_panels.toml"
    path.write_bytes(tomli_w.dumps(envisat_dict).encode())
    code, _, err = run(capsys, "run", "--truth-scenario", str(path), "--out", str(tmp_path / "r"))
    assert code == 1 and "truth scenario: panels: expected the nominal scenario's panels" in err
    assert "Traceback" not in err and not (tmp_path / "r").exists()
    with pytest.raises(SystemExit) as exc:
        main(["run", "--truth-draw", "-1"])
    assert exc.value.code == 1 and "--truth-draw: expected a seed" in capsys.readouterr().err
    code, _, err = run(capsys, "campaign", "--runs", "2", "--dispersed", "--truth-scenario", str(path),
                       "--out", str(tmp_path / "c"))
    assert code == 1 and "--truth-scenario: expected no fixed truth with --dispersed" in err


def test_campaign_json(capsys, tmp_path, caplog):
    code, out, err = run(capsys, "campaign", "--runs", "2", "--dispersed", "--duration", "3", "--cases", "mekf_flexible",
                         "--workers", "0", "--no-crlb", "--no-plots", "--json", "--out", str(tmp_path / "c"))
    assert code == 0, err
    summary = json.loads(out)
    assert summary["runs"] == 2 and "wall_s" in summary
    case = summary["cases"]["mekf_flexible"]
    for key in ("mass_error_rms_kg", "mass_error_mean_kg", "inside_3sigma_fraction", "nees_mean", "nees_band",
                "diverged_runs", "crlb_kg"):
        assert key in case
    assert (tmp_path / "c" / "campaign.nc").exists() and (tmp_path / "c" / "table.txt").exists()
    # started again: everything is loaded, and it says so
    caplog.set_level("WARNING", logger="postcapture")
    code, out, err = run(capsys, "campaign", "--runs", "2", "--dispersed", "--duration", "3", "--cases",
                         "mekf_flexible", "--workers", "0", "--no-crlb", "--no-plots", "--out", str(tmp_path / "c"))
    assert code == 0 and any("resuming: 2 of 2 runs already saved" in r.getMessage() for r in caplog.records), err
    assert max(len(line) for line in out.splitlines()) <= 80
