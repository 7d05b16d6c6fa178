"""Sine-sweep validation of the lumped chain against the plate modes (the reference's transient test).

A linear sine sweep (chirp) force along +z acts at the panel tip for ``duration`` seconds and the tip
deflection is recorded at ``n_samples`` instants ``t_k = k duration / n_samples`` (the reference:
100 s, 800 samples). The plate is solved by modal superposition
(`postcapture.panels.transient.tip_response_modal`, a uniform line load on the tip edge); the chain by
time integration of the simulated model itself: ``System(assemble_panel_chain(panel))`` driven by an
`InputSchedule` carrying the same `Chirp` on its ``force_z`` channel, mapped to joint torques through
the tip's Jacobian at rest, stepped by a Lie-group Runge-Kutta integrator; its tip deflection is the z
coordinate of the frame ``<name>_tip`` in ``<name>_root`` (the compiled core's panel outputs).

Damping is the same law in both: stiffness-proportional, ``zeta_r = beta omega_r / 2``, with
``beta = 2 zeta_1 / omega_1`` set from a damping ratio ``zeta_1`` at the reference's first bending mode;
the chain gets dampers ``d = beta k`` on its springs (``Panel.damping_beta``).

The comparison is by the single-sided amplitude spectrum ``A(f) = 2 |X(f)| / n`` (``X = rfft(x)``; DC
and Nyquist not doubled), so that a sine of amplitude ``a`` on a bin shows a peak ``a``. A 100 s
record has 0.01 Hz bins, as wide as the differences sought, so the first resonance peak is
interpolated: the record is zero-padded (16 times by default), which samples its continuous spectrum
(the DTFT that the bins sample) 16 times more finely without changing it, and a parabola through the
log-amplitude of the highest padded bin and its two neighbours refines the maximum. The parabola's own
error on a main lobe sampled 16 times per bin is negligible; what remains is the physics of a finite
record: leakage from the negative-frequency image moves the peak of a sinusoid by about 0.02 bin
(2e-4 Hz) with 8 cycles in the record and 0.002 bin with 25 (measured in the tests), against up to
half a bin for the highest bin alone, and it moves both models' peaks alike.

The chain is stepped by RK4 when its fastest linearised pole allows it, else by the L-stable SDIRK3
(fine chains with stiffness-proportional damping have fast real poles), at 20 steps per period of the
sweep's highest frequency or less; its response matches the linearised chain to a few 1e-6 of the
peak deflection under a small load (tests).
"""

from __future__ import annotations

import logging
import math
import warnings
from dataclasses import dataclass

import numpy as np

from postcapture.config.excitation import CHASER_CHANNELS, Chirp
from postcapture.config.schema import Panel
from postcapture.core.errors import DimensionError, PanelModelError, Problem
from postcapture.dynamics.assembly import assemble_panel_chain
from postcapture.dynamics.excitation import InputSchedule
from postcapture.dynamics.core import CompiledPlant
from postcapture.dynamics.modes import linearize
from postcapture.dynamics.system import System
from postcapture.panels.modes import PanelModes
from postcapture.panels.transient import tip_response_modal

__all__ = ["SweepSpec", "stiffness_damping", "amplitude_spectrum", "spectral_peak", "tip_response_fem",
           "tip_response_chain"]

logger = logging.getLogger(__name__)

_FORCE_CHANNEL = 2  # "force_z" in the input vector u = [F (3), tau (3)] of a chain without arm


def _positive(value) -> bool:
    return isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool) \
        and math.isfinite(value) and value > 0


@dataclass(frozen=True, slots=True)
class SweepSpec:
    """A linear sine sweep at the panel tip and its sampling.

    Parameters
    ----------
    f_start, f_stop : float
        Sweep frequencies at ``t = 0`` and ``t = duration`` (Hz), ``0 < f_start < f_stop`` below Nyquist.
    amplitude : float, optional
        Force amplitude along +z (N). Default 1 (the reference's Envisat test; 0.01 for the chaser).
    duration : float, optional
        Record length (s). Default 100.
    n_samples : int, optional
        Samples in the record, at ``k duration / n_samples``. Default 800.

    Raises
    ------
    PanelModelError
        With every problem (non-positive values, ``f_stop`` above the Nyquist frequency, ...).
    """

    f_start: float
    f_stop: float
    amplitude: float = 1.0
    duration: float = 100.0
    n_samples: int = 800

    def __post_init__(self):
        problems = []
        for key in ("f_start", "f_stop", "amplitude", "duration"):
            if not _positive(getattr(self, key)):
                problems.append(Problem(f"sweep.{key}", "a finite value > 0", repr(getattr(self, key))))
        n = self.n_samples
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 8:
            problems.append(Problem("sweep.n_samples", "an integer >= 8", repr(n)))
        if not problems:
            nyquist = 0.5 * n / self.duration
            if not self.f_start < self.f_stop <= nyquist:
                problems.append(Problem("sweep.f_stop", f"in ({self.f_start:g}, {nyquist:g}] Hz (above "
                                        "f_start, at most the Nyquist frequency)", repr(self.f_stop)))
        if problems:
            raise PanelModelError(problems)

    @classmethod
    def for_modes(cls, bending_hz, *, amplitude: float = 1.0, duration: float = 100.0,
                  n_samples: int = 800) -> SweepSpec:
        """Sweep from a quarter of the first to 1.25 times the last given bending frequency (Hz)."""
        f = np.atleast_1d(np.asarray(bending_hz, dtype=float))
        nyquist = 0.5 * n_samples / duration
        return cls(f_start=0.25 * float(f[0]), f_stop=min(1.25 * float(f[-1]), nyquist), amplitude=amplitude,
                   duration=duration, n_samples=n_samples)

    @property
    def sample_period(self) -> float:
        """Sampling period ``duration / n_samples`` (s)."""
        return self.duration / self.n_samples

    @property
    def times(self) -> np.ndarray:
        """Sample instants ``k duration / n_samples``, shape (n_samples,) (s)."""
        return np.arange(self.n_samples) * self.sample_period

    def profile(self) -> Chirp:
        """Return the sweep as the scenario excitation profile it is simulated with (channel ``force_z``)."""
        return Chirp(kind="chirp", channel="force_z", amplitude=self.amplitude, f0=self.f_start,
                     f1=self.f_stop, start=0.0, stop=self.duration)


def stiffness_damping(damping_ratio: float, frequency_hz: float) -> float:
    """Return the stiffness-proportional damping with a given ratio at one frequency.

    Parameters
    ----------
    damping_ratio : float
        Damping ratio ``zeta`` wanted at ``frequency_hz`` (-).
    frequency_hz : float
        Natural frequency (Hz).

    Returns
    -------
    float
        ``beta = 2 zeta / omega`` (s), so that ``d = beta k`` gives ``zeta_r = beta omega_r / 2``.
    """
    return 2.0 * damping_ratio / (2.0 * math.pi * frequency_hz)


def amplitude_spectrum(x, sample_period: float, *, zero_pad: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Single-sided amplitude spectrum of a real record.

    Parameters
    ----------
    x : array_like, shape (n,)
        Uniformly sampled record (any unit).
    sample_period : float
        Sampling period (s).
    zero_pad : int, optional
        Transform length as a multiple of ``n`` (zeros appended). Default 1.

    Returns
    -------
    freqs : ndarray, shape (n zero_pad // 2 + 1,)
        Frequencies (Hz).
    amplitude : ndarray, same shape
        ``2 |rfft(x)| / n`` (unit of ``x``); DC and the Nyquist bin (even lengths) are not doubled.

    Raises
    ------
    DimensionError
        If ``x`` is not 1-D with at least 2 samples.
    PanelModelError
        If the period is not positive or ``zero_pad`` not a positive integer.
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.size < 2:
        raise DimensionError(f"`x` must be 1-D with at least 2 samples; found shape {x.shape}")
    pad_ok = isinstance(zero_pad, (int, np.integer)) and not isinstance(zero_pad, bool) and zero_pad >= 1
    if not (_positive(sample_period) and pad_ok):
        raise PanelModelError([Problem("sample_period, zero_pad", "a period > 0 s and an integer >= 1",
                                       f"{sample_period!r}, {zero_pad!r}")])
    m = x.size * int(zero_pad)
    amp = np.abs(np.fft.rfft(x, n=m)) / x.size
    amp[1:] *= 2.0
    if m % 2 == 0:
        amp[-1] *= 0.5
    return np.fft.rfftfreq(m, sample_period), amp


def spectral_peak(x, sample_period: float, *, band, zero_pad: int = 16) -> tuple[float, float]:
    """Locate the highest peak of the amplitude spectrum in a band, between bins.

    Parameters
    ----------
    x : array_like, shape (n,)
        Uniformly sampled record.
    sample_period : float
        Sampling period (s).
    band : tuple of float
        ``(f_low, f_high)`` searched (Hz).
    zero_pad : int, optional
        Zero-padding factor before the parabolic refinement (see the module text). Default 16.

    Returns
    -------
    frequency : float
        Interpolated peak frequency (Hz).
    amplitude : float
        Interpolated peak amplitude (unit of ``x``).

    Raises
    ------
    PanelModelError
        If the band is empty or holds fewer than three padded bins.

    Warns
    -----
    RuntimeWarning
        When the maximum lies on the band's edge (no resonance inside the band).
    """
    f_lo, f_hi = (float(b) for b in band)
    freqs, amp = amplitude_spectrum(x, sample_period, zero_pad=zero_pad)
    inside = np.flatnonzero((freqs >= f_lo) & (freqs <= f_hi))
    if not f_lo < f_hi or inside.size < 3:
        raise PanelModelError([Problem("band", "an interval holding at least three spectral bins",
                                       f"({f_lo:g}, {f_hi:g}) Hz")])
    i = int(inside[np.argmax(amp[inside])])
    if i in (inside[0], inside[-1]):
        warnings.warn(f"the spectrum's maximum in ({f_lo:g}, {f_hi:g}) Hz is on the band's edge: no peak "
                      "inside", RuntimeWarning, stacklevel=2)
        return float(freqs[i]), float(amp[i])
    y0, y1, y2 = np.log(np.maximum(amp[i - 1:i + 2], np.finfo(float).tiny))
    curvature = y0 - 2.0 * y1 + y2
    delta = 0.5 * (y0 - y2) / curvature if curvature < 0 else 0.0
    df = freqs[1] - freqs[0]
    return float(freqs[i] + delta * df), float(np.exp(y1 - 0.25 * (y0 - y2) * delta))


def tip_response_fem(modes: PanelModes, spec: SweepSpec, *, beta: float, substeps: int = 16) -> np.ndarray:
    """Tip deflection of the plate modes under the sweep, by modal superposition.

    Parameters
    ----------
    modes : PanelModes
        Mass-normalised plate modes (all of them are superposed).
    spec : SweepSpec
        The sweep and its sampling.
    beta : float
        Stiffness-proportional damping (s): mode ``r`` gets ``zeta_r = beta omega_r / 2``.
    substeps : int, optional
        The load is sampled ``substeps`` times per sample period for the first-order hold of the
        modal integration, then the response is taken at the samples. Default 16.

    Returns
    -------
    ndarray, shape (n_samples,)
        Tip deflection along z at ``spec.times`` (m).
    """
    fine = np.arange((spec.n_samples - 1) * substeps + 1) * (spec.sample_period / substeps)
    zeta = 0.5 * beta * 2.0 * np.pi * modes.frequencies_hz
    load = InputSchedule([spec.profile()], 0).sample(fine)[CHASER_CHANNELS.index("force_z")]
    w = tip_response_modal(modes, load, fine, damping_ratio=zeta)
    return w[::substeps]


def _input_matrix(system: System, q: np.ndarray) -> np.ndarray:
    """``B`` (nv x n_u): the z force at the tip mapped to joint torques by the tip Jacobian at ``q``.

    The chain's root frame is the base's (fixed, world-aligned), so the z row of the tip's translation
    Jacobian is the core's panel-output Jacobian row of the tip's z deflection.
    """
    jac = CompiledPlant(system).panel_jacobian(q)
    b = np.zeros((system.nv, system.n_u))
    b[:, _FORCE_CHANNEL] = jac[2]
    return b


def tip_response_chain(panel: Panel, spec: SweepSpec, *, integrator: str | None = None,
                       max_step: float | None = None) -> np.ndarray:
    """Tip deflection of the simulated panel chain under the sweep, by time integration.

    Parameters
    ----------
    panel : Panel
        The chain (its ``damping_beta`` gives the dampers ``d = beta k``).
    spec : SweepSpec
        The sweep and its sampling.
    integrator : {"rk4", "sdirk3", "sdirk2"}, optional
        Fixed-step integrator of the compiled core (`postcapture.dynamics.core`). Default: ``"rk4"`` when its
        stability limit ``1 / |lambda|_max`` (the linearised chain's fastest pole) allows at least a
        quarter of the accuracy step ``1 / (20 f_stop)``, else the L-stable ``"sdirk3"`` (fine chains
        with stiffness-proportional damping have fast real poles).
    max_step : float, optional
        Largest step (s). Default ``1 / (20 f_stop)`` (20 steps per period of the fastest forcing),
        and for RK4 at most ``1 / |lambda|_max``.

    Returns
    -------
    ndarray, shape (n_samples,)
        z of the tip frame in the root frame at ``spec.times`` (m), starting at rest.

    Raises
    ------
    SimulationError
        If the integration fails.
    """
    asm = assemble_panel_chain(panel)
    probe = System(asm)
    q = asm.q_rest.copy()
    v = np.zeros(probe.nv)
    system = System(asm, inputs=InputSchedule([spec.profile()], 0), input_matrix=_input_matrix(probe, q))
    h_accuracy = 1.0 / (20.0 * spec.f_stop) if max_step is None else float(max_step)
    fastest = float(np.max(np.abs(np.linalg.eigvals(linearize(system, q, v).A))))
    h_stable = 1.0 / max(fastest, 1e-12)
    if integrator is None:
        integrator = "rk4" if h_stable >= 0.25 * h_accuracy else "sdirk3"
    h_max = min(h_accuracy, h_stable) if integrator == "rk4" else h_accuracy
    substeps = max(1, math.ceil(spec.sample_period / h_max - 1e-9))
    h = spec.sample_period / substeps
    run = CompiledPlant(system, integrator).simulate(q, v, 0.0, h, substeps, spec.n_samples,
                                                     sample_period=spec.sample_period)
    out = run["panels"][:, 0, 2]  # the tip's z in the root frame
    logger.debug("chain %s: %d steps of %.4g s (%s)", panel.name, (spec.n_samples - 1) * substeps, h,
                 integrator)
    return out
