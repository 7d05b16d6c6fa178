"""Nastran interchange hardening: the deck ends with ENDDATA; an OP2 reference far from the project's own
FEM of the panel (its mass, its first frequencies) is refused unless forced."""

import dataclasses

import json

import numpy as np
import pytest
from panel_cases import write_modes_op2

import pyNastran  # noqa: F401 - the panels extra is part of the test install

from postcapture.core.errors import NastranError, OutputPathError
from postcapture.panels import builtin_panel, calibrate, read_op2_modes, solve_modes, write_bdf
from postcapture.panels.calibrate import OP2_TOLERANCE, compare_with_fem
from postcapture.panels.mesh import panel_mesh


def test_the_deck_ends_with_enddata(tmp_path):
    geometry, laminate = builtin_panel("chaser")
    path = tmp_path / "chaser.bdf"
    write_bdf(path, geometry, laminate, n_length=6, n_width=2, n_modes=4)
    lines = [line.strip() for line in path.read_text().splitlines() if line.strip()]
    assert lines[-1] == "ENDDATA" and lines.count("ENDDATA") == 1
    assert lines.index("BEGIN BULK") < len(lines) - 1
    with pytest.raises(OutputPathError, match="a character device, not a regular file"):
        write_bdf("/dev/null", geometry, laminate, n_length=6, n_width=2)


def _op2(path, modes):
    write_modes_op2(path, np.arange(1, modes.mesh.n_nodes + 1), modes.shapes, modes.frequencies_hz)
    return read_op2_modes(path).to_panel_modes(modes.mesh)


def test_same_panel_agrees_with_the_fem(envisat_modes, tmp_path):
    geometry, laminate = builtin_panel("envisat")
    cmp = compare_with_fem(_op2(tmp_path / "same.op2", envisat_modes), geometry, laminate)
    assert cmp["mass_ratio"] == pytest.approx(1.0, abs=1e-5)  # float32 shapes in the file
    np.testing.assert_allclose(cmp["frequency_ratios"], 1.0, atol=1e-6)
    assert cmp["frequencies_hz"].size == OP2_TOLERANCE["modes"]


@pytest.fixture(scope="module")
def heavy_op2(tmp_path_factory):
    """The Envisat wing with its solar-cell mass raised so that the panel weighs 3.5 times as much."""
    geometry, laminate = builtin_panel("envisat")
    structure = laminate.areal_mass - laminate.cell_mass
    heavy = dataclasses.replace(laminate, cell_mass=3.5 * laminate.areal_mass - structure)
    modes = solve_modes(geometry, heavy, n_length=60, n_width=20, n_modes=10)
    path = tmp_path_factory.mktemp("op2") / "heavy.op2"
    write_modes_op2(path, np.arange(1, modes.mesh.n_nodes + 1), modes.shapes, modes.frequencies_hz)
    return path


def test_the_implied_mass_and_frequencies_of_a_wrong_panel(heavy_op2):
    geometry, laminate = builtin_panel("envisat")
    modes = read_op2_modes(heavy_op2).to_panel_modes(panel_mesh(geometry, n_length=60, n_width=20))
    cmp = compare_with_fem(modes, geometry, laminate)
    # translational mass scales exactly with the areal mass; rotary inertia of the plies a little less
    assert cmp["mass_ratio"] == pytest.approx(3.5, rel=0.03)
    np.testing.assert_allclose(cmp["frequency_ratios"], 1 / np.sqrt(3.5), rtol=0.03)  # same stiffness


def test_a_wrong_op2_is_refused_unless_forced(heavy_op2, caplog):
    with pytest.raises(NastranError, match=r"heavy\.op2: the OP2 reference differs from the project's own FEM of "
                                           r"this panel in mass and frequencies.*imply 3\.[45]\d* times.*"
                                           r"--force-reference"):
        calibrate("envisat", weights=(0.1,), reference=heavy_op2)
    forced = calibrate("envisat", weights=(0.1,), reference=heavy_op2, force_reference=True)
    assert "beyond the tolerance; forced" in forced.reference and "forced" in caplog.text
    # a program tells a forced calibration from a good one (issue 18), and the warning says what happened
    assert json.loads(forced.to_json())["forced_reference"] is True
    assert "Used anyway, as --force-reference asks" in caplog.text and "; forced" not in caplog.text
    right = calibrate("envisat", weights=(0.1,))
    assert json.loads(right.to_json())["forced_reference"] is False
    # what the check prevents: the fit on the heavy panel's modes gives far softer springs
    assert np.all(forced.runs["w=0.1"].k < 0.5 * right.runs["w=0.1"].k)


def test_the_cli_refuses_it_with_one_message(heavy_op2, capsys):
    from postcapture.cli import main

    code = main(["panel", "calibrate", "--reference", str(heavy_op2), "--weights", "0.1"])
    out, err = capsys.readouterr()
    assert code == 1 and out == "" and "Traceback" not in err
    assert err.startswith("postcapture: error: ") and "(--force-reference)" in err and err.count("error:") == 1
