"""Sine-sweep validation: spectrum scaling, interpolated peak, chain integration against linear solutions."""

import numpy as np
import pytest
from scipy.signal import lsim

from postcapture.core.errors import DimensionError, PanelModelError
from postcapture.dynamics.excitation import InputSchedule
from postcapture.panels import LumpedChain, SweepSpec, amplitude_spectrum, chain_panel, spectral_peak
from postcapture.panels.sweep import stiffness_damping, tip_response_chain, tip_response_fem
from postcapture.panels.transient import tip_response_modal

DT, N = 0.125, 800  # the reference's record: 100 s, 800 samples, 0.01 Hz bins
T = np.arange(N) * DT


def chirp_load(spec, t):
    """The sweep's force in closed form: a linear chirp from f_start to f_stop on [0, duration)."""
    rate = (spec.f_stop - spec.f_start) / spec.duration
    load = spec.amplitude * np.sin(2 * np.pi * (spec.f_start * t + 0.5 * rate * t**2))
    return np.where((t >= 0.0) & (t < spec.duration), load, 0.0)


@pytest.mark.parametrize("n", [800, 801])
def test_a_sine_of_amplitude_a_on_a_bin_shows_a_peak_a(n):
    t = np.arange(n) * DT
    f0 = 25 / (n * DT)  # exactly on bin 25
    freqs, amp = amplitude_spectrum(0.7 + 2.5 * np.sin(2 * np.pi * f0 * t + 0.3), DT)
    assert freqs[25] == pytest.approx(f0) and amp[25] == pytest.approx(2.5, rel=1e-12)
    assert amp[0] == pytest.approx(0.7, rel=1e-12)  # DC is not doubled
    assert freqs.size == n // 2 + 1 and freqs[1] == pytest.approx(1 / (n * DT))
    _, amp_pad = amplitude_spectrum(2.5 * np.sin(2 * np.pi * f0 * t), DT, zero_pad=4)
    assert amp_pad[100] == pytest.approx(2.5, rel=1e-12)  # padding samples the same spectrum


def test_nyquist_bin_is_not_doubled():
    x = np.cos(np.pi * np.arange(N))  # +1, -1, ...: all at Nyquist
    _, amp = amplitude_spectrum(x, DT)
    assert amp[-1] == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("f0, tol_bins", [(0.2537, 0.005), (1.2345, 0.002), (0.0837, 0.02)])
def test_interpolated_peak_of_a_sinusoid_between_bins(f0, tol_bins):
    """Bins are 0.01 Hz: the bin maximum is off by up to half a bin, the interpolated peak by < 0.02 bin
    (what remains is leakage from the negative-frequency image, largest with few cycles in the record)."""
    x = 1.5 * np.sin(2 * np.pi * f0 * T + 0.4)
    f, a = spectral_peak(x, DT, band=(0.03, 3.0))
    freqs, amp = amplitude_spectrum(x, DT)
    assert abs(freqs[np.argmax(amp)] - f0) > 0.3 * 0.01
    assert abs(f - f0) < tol_bins * 0.01
    assert a == pytest.approx(1.5, rel=0.02)


def test_interpolated_peak_of_a_free_damped_resonance():
    fd, zeta = 0.0805, 0.01
    x = np.exp(-zeta * 2 * np.pi * fd * T) * np.sin(2 * np.pi * fd * T)
    f, _ = spectral_peak(x, DT, band=(0.03, 0.2))
    assert abs(f - fd) < 0.025 * 0.01


def test_peak_on_the_band_edge_warns_and_bad_bands_raise():
    x = np.exp(-T / 2.0)  # a Lorentzian spectrum, falling from DC: no peak away from 0
    with pytest.warns(RuntimeWarning, match="band's edge"):
        f, _ = spectral_peak(x, DT, band=(0.1, 0.3))
    assert f == pytest.approx(0.1, abs=1e-3)
    with pytest.raises(PanelModelError, match="band: expected an interval holding at least three"):
        spectral_peak(x, DT, band=(0.3, 0.1))
    with pytest.raises(DimensionError, match="1-D with at least 2 samples"):
        amplitude_spectrum(np.ones((3, 3)), DT)
    with pytest.raises(PanelModelError, match="sample_period, zero_pad"):
        amplitude_spectrum(x, DT, zero_pad=0)


def test_sweep_spec_defaults_and_validation():
    spec = SweepSpec.for_modes([0.08, 0.5, 1.4])
    assert (spec.duration, spec.n_samples, spec.sample_period) == (100.0, 800, 0.125)
    assert spec.f_start == pytest.approx(0.02) and spec.f_stop == pytest.approx(1.75)
    t = np.concatenate([spec.times, [spec.duration]])
    force_z = InputSchedule([spec.profile()], 0).sample(t)[2]  # the profile as simulated, on force_z
    t3 = t[:3]
    np.testing.assert_allclose(force_z[:3], np.sin(2 * np.pi * (0.02 * t3 + 0.5 * (1.73 / 100) * t3**2)))
    np.testing.assert_allclose(force_z, chirp_load(spec, t), rtol=0, atol=1e-12)
    assert force_z[-1] == 0.0  # off at the stop
    with pytest.raises(PanelModelError, match=r"sweep.f_stop: expected in \(0.1, 4\] Hz"):
        SweepSpec(f_start=0.1, f_stop=5.0)
    with pytest.raises(PanelModelError) as info:
        SweepSpec(f_start=-1.0, f_stop=1.0, amplitude=0.0, n_samples=4)
    assert len(info.value.problems) == 3


def linear_chain_response(panel, spec):
    """The linearised chain in joint coordinates: M th'' + beta K th' + K th = J^T F, w_tip = J th."""
    chain = LumpedChain(panel)
    b = chain.bending_index
    m = chain.mass_matrix[np.ix_(b, b)]
    k = chain.stiffness_matrix(panel.bending_stiffness, panel.torsion_stiffness)[np.ix_(b, b)]
    j = -(panel.length - panel.length / panel.segments * np.arange(panel.segments))  # d w_tip / d theta_j
    n = panel.segments
    minv = np.linalg.inv(m)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ k, -panel.damping_beta * minv @ k]])
    bb = np.concatenate([np.zeros(n), minv @ j])[:, None]
    sub = 32
    fine = np.arange((spec.n_samples - 1) * sub + 1) * (spec.sample_period / sub)
    c = np.concatenate([j, np.zeros(n)])[None, :]
    _, y, _ = lsim((a, bb, c, np.zeros((1, 1))), chirp_load(spec, fine), fine)
    return y[::sub]


@pytest.mark.parametrize("n", [2, 5])
def test_chain_sweep_response_is_the_linear_chain_with_stiffness_proportional_damping(n):
    """Small load: the integrated multibody chain (tip frame placement) equals its linearisation."""
    spec = SweepSpec(f_start=0.02, f_stop=1.0, amplitude=1e-3)
    panel = chain_panel("wing", length=14.0, width=5.0, mass=336.0,
                        bending_stiffness=np.linspace(2e4, 6e3, n), torsion_stiffness=1e3,
                        damping_beta=stiffness_damping(0.01, 0.08))
    w = tip_response_chain(panel, spec)
    ref = linear_chain_response(panel, spec)
    assert np.max(np.abs(w - ref)) < 1e-4 * np.max(np.abs(ref))


def test_single_hinge_sweep_response_is_the_closed_form_oscillator():
    """One segment: w'' + beta w0^2 w' + w0^2 w = (L^2 / I) F with I = m L^2 / 3 and w0^2 = k / I."""
    length, mass, k = 14.0, 336.0, 2.0e4
    beta = stiffness_damping(0.02, 0.1)
    spec = SweepSpec(f_start=0.02, f_stop=1.0, amplitude=1e-3)
    panel = chain_panel("wing", length=length, width=5.0, mass=mass, bending_stiffness=[k],
                        torsion_stiffness=1e3, damping_beta=beta)
    inertia = mass * length**2 / 3
    w0 = np.sqrt(k / inertia)
    sub = 32
    fine = np.arange((spec.n_samples - 1) * sub + 1) * (spec.sample_period / sub)
    _, y, _ = lsim(([length**2 / inertia], [1.0, beta * w0**2, w0**2]), chirp_load(spec, fine), fine)
    w = tip_response_chain(panel, spec)
    assert np.max(np.abs(w - y[::sub])) < 1e-4 * np.max(np.abs(y))


def test_fem_sweep_is_modal_superposition_with_the_same_damping_law(envisat_modes):
    spec = SweepSpec(f_start=0.02, f_stop=1.0, duration=20.0, n_samples=160)
    beta = stiffness_damping(0.02, envisat_modes.frequency("bending"))
    w = tip_response_fem(envisat_modes, spec, beta=beta, substeps=1)
    zeta = 0.5 * beta * 2 * np.pi * envisat_modes.frequencies_hz
    ref = tip_response_modal(envisat_modes, chirp_load(spec, spec.times), spec.times, damping_ratio=zeta)
    np.testing.assert_allclose(w, ref, rtol=0, atol=1e-14)
    assert zeta[envisat_modes.indices("bending")[0]] == pytest.approx(0.02)
