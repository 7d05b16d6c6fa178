"""Modal superposition of the tip response against closed forms (step response, static deflection)."""

import numpy as np
import pytest

from postcapture.core.errors import DimensionError, PanelModelError
from postcapture.panels import solve_modes, tip_response_modal
from postcapture.panels.transient import tip_edge_weights


@pytest.fixture(scope="module")
def strip_modes(strip):
    return solve_modes(strip.geometry, strip.laminate, n_length=40, n_width=2, n_modes=12)


def test_single_mode_step_response_is_the_damped_oscillator_closed_form(strip_modes):
    t = np.linspace(0.0, 5.0, 801)
    force = np.full_like(t, 0.3)
    zeta = 0.02
    w = tip_response_modal(strip_modes, force, t, damping_ratio=zeta, n_modes=1)
    nodes, share = tip_edge_weights(strip_modes)
    g = share @ strip_modes.shapes[nodes, 2, 0]
    om = 2 * np.pi * strip_modes.frequencies_hz[0]
    wd = om * np.sqrt(1 - zeta**2)
    decay = np.exp(-zeta * om * t) * (np.cos(wd * t) + zeta / np.sqrt(1 - zeta**2) * np.sin(wd * t))
    ref = 0.3 * g**2 / om**2 * (1 - decay)
    np.testing.assert_allclose(w, ref, atol=1e-10 * np.max(np.abs(ref)))


def test_ramp_is_integrated_exactly_between_samples(strip_modes):
    """A load linear in time is represented exactly by the first-order hold: coarse and fine grids agree
    at the common instants (the undamped oscillator's ramp response has a closed form too)."""
    coarse = np.linspace(0.0, 4.0, 41)
    fine = np.linspace(0.0, 4.0, 401)
    w_c = tip_response_modal(strip_modes, 0.1 * coarse, coarse, damping_ratio=0.0, n_modes=1)
    w_f = tip_response_modal(strip_modes, 0.1 * fine, fine, damping_ratio=0.0, n_modes=1)
    np.testing.assert_allclose(w_c, w_f[::10], atol=1e-12 * np.max(np.abs(w_f)))
    nodes, share = tip_edge_weights(strip_modes)
    g = share @ strip_modes.shapes[nodes, 2, 0]
    om = 2 * np.pi * strip_modes.frequencies_hz[0]
    np.testing.assert_allclose(w_c, 0.1 * g**2 / om**2 * (coarse - np.sin(om * coarse) / om),
                               atol=1e-10 * np.max(np.abs(w_c)))


def test_settled_response_is_the_static_cantilever_deflection(strip, strip_modes):
    """A constant tip force, heavily damped: w -> F L^3 / (3 EI) (truncation at 12 modes < 0.1 %)."""
    t = np.linspace(0.0, 30.0, 3001)
    w = tip_response_modal(strip_modes, np.ones_like(t), t, damping_ratio=0.5)
    assert w[-1] == pytest.approx(strip.length**3 / (3 * strip.ei), rel=1e-3)


def test_sine_sweep_on_the_reference_grid_peaks_at_the_first_bending_mode(envisat_modes):
    """The reference's record: 100 s, 800 samples; the response spectrum peaks within one bin of f1."""
    t = np.arange(800) * (100.0 / 800)
    f0, f1 = 0.01, 0.3
    force = np.sin(2 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2 * 100.0)))
    w = tip_response_modal(envisat_modes, force, t, damping_ratio=0.02)
    spectrum = np.abs(np.fft.rfft(w))
    freqs = np.fft.rfftfreq(t.size, t[1] - t[0])
    assert abs(freqs[np.argmax(spectrum[1:]) + 1] - envisat_modes.frequency("bending")) <= 0.01 + 1e-12


def test_bad_transient_input(strip_modes):
    t = np.linspace(0.0, 1.0, 11)
    with pytest.raises(DimensionError, match="same length"):
        tip_response_modal(strip_modes, np.ones(5), t)
    with pytest.raises(PanelModelError, match="times: expected a uniform, increasing grid"):
        tip_response_modal(strip_modes, np.ones(11), t**2)
    with pytest.raises(PanelModelError, match="damping_ratio: expected finite values >= 0"):
        tip_response_modal(strip_modes, np.ones(11), t, damping_ratio=-0.1)
    with pytest.raises(PanelModelError, match=r"n_modes: expected an integer in \[1, 12\]"):
        tip_response_modal(strip_modes, np.ones(11), t, n_modes=13)
    with pytest.raises(PanelModelError, match="tip_force: expected finite values"):
        tip_response_modal(strip_modes, np.full(11, np.nan), t)
