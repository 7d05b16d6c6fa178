"""Strict scenario types, extreme numbers and the segment cap (issue: every bad input a clear error)."""

import math

import numpy as np
import pytest

from postcapture.config import scenario_from_dict
from postcapture.config.excitation import channel_index
from postcapture.config.schema import MAX_SEGMENTS
from postcapture.core.errors import ScenarioError


def test_a_boolean_is_not_a_mass(envisat_dict):
    envisat_dict["target"]["mass"] = True
    with pytest.raises(ScenarioError, match=r"target\.mass: expected a number, found true \(a boolean\)"):
        scenario_from_dict(envisat_dict)


@pytest.mark.parametrize(
    ("where", "value", "message"),
    [
        (("chaser", "mass"), "1600", r"chaser\.mass: expected a number, found '1600'"),
        (("chaser", "panels", 0, "segments"), 5.0, r"segments: expected an integer, found 5\.0"),
        (("chaser", "properties_include_panels"), 1, r"properties_include_panels: expected true or false, found 1"),
        (("estimation", "seed"), False, r"estimation\.seed: expected an integer, found false"),
        (("initial", "omega_BN_B"), [0.0, True, 0.0], r"initial\.omega_BN_B\[1\]: expected a number"),
    ],
)
def test_no_lax_conversions(envisat_dict, where, value, message):
    node = envisat_dict
    for key in where[:-1]:
        node = node[key]
    node[where[-1]] = value
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(envisat_dict)


def test_integers_are_numbers_and_numpy_values_are_python_values(envisat_dict):
    envisat_dict["chaser"]["mass"] = 1600
    envisat_dict["chaser"]["panels"][0]["segments"] = np.int64(5)
    envisat_dict["initial"]["omega_BN_B"] = np.array([0.0, 0.01, 0.02])
    sc = scenario_from_dict(envisat_dict)
    assert sc.chaser.mass == 1600.0 and sc.chaser.panels[0].segments == 5
    assert sc.initial.omega_BN_B == (0.0, 0.01, 0.02)


@pytest.mark.parametrize("digit", ["\u0663", "\uff13", "\u09e9", "\U0001d7d1"])  # Arabic-Indic, fullwidth, Bengali, math bold 3
def test_a_joint_channel_takes_ascii_digits_only(envisat_dict, digit):
    assert int(digit) == 3  # what int() would have read
    envisat_dict["excitation"][3]["channel"] = f"joint_{digit}"
    with pytest.raises(ScenarioError, match=r"excitation\[3\]: expected a channel among"):
        scenario_from_dict(envisat_dict)
    with pytest.raises(ValueError, match="unknown channel"):
        channel_index(f"joint_{digit}", 7)
    assert channel_index("joint_3", 7) == 8
    for bad in ("joint_0", "joint_03", "joint_+3", "joint_ 3", "joint_3 "):
        with pytest.raises(ValueError):
            channel_index(bad, 7)


@pytest.mark.parametrize(("period", "match"), [
    (1e308, r"simulation\.sample_period: expected a number <= 1000\.0"),  # bounded before 1e308 / 0.1 overflows
    (math.ulp(0.0) * 3, r"simulation: expected sample_period between"),
])
def test_extreme_sample_period_is_a_scenario_error(envisat_dict, period, match):
    envisat_dict["simulation"]["sample_period"] = period
    with pytest.raises(ScenarioError, match=match):
        scenario_from_dict(envisat_dict)


def test_huge_inertia_is_refused_without_overflow(envisat_dict):
    envisat_dict["chaser"]["inertia"] = [[1e300, 0, 0], [0, 1e300, 0], [0, 0, 1e300]]
    with pytest.raises(ScenarioError, match=r"chaser\.inertia: expected inertia entries of magnitude at most 1e\+10 kg m\^2"):
        scenario_from_dict(envisat_dict)


@pytest.mark.parametrize("n", [0, MAX_SEGMENTS + 1, 1_000_000_000, 2.5, True])
def test_panel_segments_cap_cannot_be_bypassed(envisat, n):
    with pytest.raises(ScenarioError, match=rf"segments: expected an integer in \[1, {MAX_SEGMENTS}\]"):
        envisat.with_panel_segments(n)


def test_with_panel_segments_returns_a_validated_copy(envisat):
    sc = envisat.with_panel_segments(8)
    assert all(p.segments == 8 and len(p.bending_stiffness) == 8 for _, p in sc.panels())
    assert type(sc).model_validate(sc.model_dump()) == sc


@pytest.mark.parametrize("seed", [-1, 2**63, 1180591620717411303424])
def test_a_seed_fits_the_results_file(envisat_dict, seed):
    envisat_dict["estimation"]["seed"] = seed  # written as an int64 attribute at the very end of a run
    with pytest.raises(ScenarioError, match=r"estimation\.seed: expected a number (>=|<) "):
        scenario_from_dict(envisat_dict)
