"""The built-in panels meet their design statements (mass range, symmetry, Euler-Bernoulli estimate)."""

import pytest
from panel_cases import beam_frequency

from postcapture.core.errors import PanelModelError
from postcapture.panels import builtin_geometry, builtin_laminate, builtin_panel


def test_envisat_wing_design():
    geometry, laminate = builtin_panel("envisat")
    assert (geometry.length, geometry.width) == (14.0, 5.0)
    mass = laminate.areal_mass * geometry.area
    assert 300.0 <= mass <= 350.0  # physical-data.md: plausible 300-350 kg
    core = max(laminate.plies, key=lambda p: p.thickness)
    assert core.thickness == pytest.approx(8e-3) and core.material.name == "AL_HONEYCOMB"
    assert laminate.is_symmetric()
    _, _, d = laminate.abd()
    assert abs(d[0, 2]) + abs(d[1, 2]) < 1e-12 * d[0, 0]  # cross-ply faces: no bending-twisting coupling
    assert beam_frequency(geometry, laminate) == pytest.approx(0.080, rel=0.01)


def test_chaser_panel_design():
    geometry, laminate = builtin_panel("chaser")
    assert (geometry.length, geometry.width) == (5.0, 2.0)
    assert laminate.areal_mass * geometry.area == pytest.approx(30.0, rel=0.05)  # "about 30 kg"
    assert max(p.thickness for p in laminate.plies) == pytest.approx(2e-3)
    assert laminate.is_symmetric()


def test_builtin_accessors_agree():
    assert builtin_geometry("chaser") == builtin_panel("chaser")[0]
    assert builtin_laminate("envisat") == builtin_panel("envisat")[1]


def test_unknown_builtin_panel():
    with pytest.raises(PanelModelError, match="panel: expected one of envisat, chaser, found 'hubble'"):
        builtin_laminate("hubble")
