"""scikit-fem's Kirchhoff plate (Morley triangles) cross-checks the pyfe3d shell."""

import numpy as np
import pytest

from postcapture.core.errors import PanelModelError
from postcapture.panels import builtin_panel, solve_modes_kirchhoff


def test_kirchhoff_strip_matches_euler_bernoulli(strip):
    plate = solve_modes_kirchhoff(strip.geometry, strip.laminate, n_length=60, n_width=4, n_modes=3)
    assert plate.frequency("bending") == pytest.approx(strip.euler_bernoulli_hz(1), rel=2e-3)


def test_kirchhoff_and_shell_agree_on_the_envisat_wing(envisat_modes):
    """Both on the 20 x 60 grid (the plate with 2400 triangles). Tolerance 1 %: Morley converges from below,
    the shell from above, and their 20 x 60 errors on the fourth out-of-plane mode are a few tenths of a
    percent each (the finer 40 x 120 plate moves the fourth mode by 0.4 %)."""
    geometry, laminate = builtin_panel("envisat")
    plate = solve_modes_kirchhoff(geometry, laminate, n_length=60, n_width=20, n_modes=4)
    shell = [i for i, k in enumerate(envisat_modes.kinds) if k != "in-plane"][:4]
    assert plate.kinds == tuple(envisat_modes.kinds[i] for i in shell)
    np.testing.assert_allclose(plate.frequencies_hz, envisat_modes.frequencies_hz[shell], rtol=1e-2)
    # the first bending and torsion frequencies, which the identification uses, agree to 0.3 %
    for kind in ("bending", "torsion"):
        assert plate.frequency(kind) == pytest.approx(envisat_modes.frequency(kind), rel=3e-3)


def test_kirchhoff_bad_input(strip):
    with pytest.raises(PanelModelError, match=r"n_width: expected an integer >= 1"):
        solve_modes_kirchhoff(strip.geometry, strip.laminate, n_width=0)
    with pytest.raises(PanelModelError, match=r"n_modes: expected an integer in \[1, "):
        solve_modes_kirchhoff(strip.geometry, strip.laminate, n_length=2, n_width=1, n_modes=50)
    plate = solve_modes_kirchhoff(strip.geometry, strip.laminate, n_length=4, n_width=1, n_modes=2)
    with pytest.raises(PanelModelError, match="torsion mode 3"):
        plate.frequency("torsion", 3)
