"""Options and help follow the schema and say the same thing everywhere (issue 18's reproducers)."""

import pytest

from postcapture.cli import build_parser, main
from postcapture.config.names import INTEGRATORS, PROFILES


def _help(*argv) -> str:
    """The help text of a subcommand, as ``postcapture ... --help`` prints it (in this process)."""
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as exc:
        main([*argv, "--help"])
    assert exc.value.code == 0
    return " ".join(out.getvalue().split())


@pytest.mark.parametrize("argv", [["run", "--no-progress", "--help"], ["run", "-v", "--help"],
                                  ["campaign", "--progress", "--help"], ["scenario", "validate", "-v", "--help"]])
def test_global_options_after_the_subcommand(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 0, capsys.readouterr().err


def test_global_options_land_where_the_commands_read_them():
    parser = build_parser()
    assert parser.parse_args(["run", "--no-progress"]).progress == "off"
    assert parser.parse_args(["--no-progress", "run"]).progress == "off"
    assert parser.parse_args(["run", "-v"]).verbose is True
    assert parser.parse_args(["run"]).progress == "auto" and parser.parse_args(["run"]).verbose is False


def test_choices_are_the_schemas():
    parser = build_parser()
    for integrator in INTEGRATORS:  # sdirk4, the accurate truth's integrator, was refused
        assert parser.parse_args(["simulate", "--integrator", integrator]).integrator == integrator
    assert parser.parse_args(["fmu", "export", "--fmi", "3", "-o", "x.fmu"]).fmi == 3  # implemented now
    with pytest.raises(SystemExit):
        parser.parse_args(["fmu", "export", "--fmi", "1", "-o", "x.fmu"])
    for profile in PROFILES:
        assert parser.parse_args(["run", "--profile", profile]).profile == profile


def test_help_texts_agree_with_the_library(monkeypatch):
    from postcapture.studies.cases import DEFAULT_CASES

    monkeypatch.setenv("COLUMNS", "200")  # lines long enough that no list is broken

    run, campaign = _help("run"), _help("campaign")
    assert f"(default: {','.join(DEFAULT_CASES)})" in run  # the default cases, as the library has them
    assert "default: reference; campaign's default is realistic" in run
    assert "default: realistic; run's default is reference" in campaign
    for text in (run, campaign):
        assert "added to the nominal target mass" in text and "true mass" not in text
    assert "Pinocchio" not in run
    assert "FMI version: 2 (2.0) or 3 (3.0)" in _help("fmu", "export")
    assert "sdirk4" in _help("simulate")
