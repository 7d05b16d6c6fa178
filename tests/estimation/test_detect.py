r"""Change detection and the model-validity monitor against closed forms
(:mod:`postcapture.estimation.detect`).

Reference figures for a one-sided CUSUM ``g_k = max(0, g_{k-1} + x_k - kappa)`` on unit-variance Gaussian
``x`` of mean ``mu``, alarm at ``g > h`` (Siegmund, *Sequential Analysis*, 1985, eq. 2.57; Basseville and
Nikiforov 1993, eq. 5.2.44): with ``b = h + 1.166`` (twice the mean overshoot of a Gaussian random walk
over a boundary, 0.583 sigma) and ``d = mu - kappa``,

.. math::

    ARL(d) \approx \frac{e^{-2 d b} + 2 d b - 1}{2 d^2},

the mean run length from ``g = 0``; for ``d > 0`` it is Wald's ``b / d`` less ``1 / (2 d^2)``, the first
passage of a random walk with drift ``d`` through ``b`` (inverse Gaussian: variance ``b / d^3``). A
two-sided CUSUM alarms at the first of its two sides: ``1/ARL = 1/ARL+ + 1/ARL-``.
"""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.stats import chi2, norm

from postcapture.estimation.detect import ChangeDetector, DetectionPolicy, ValidityMonitor

OVERSHOOT = 1.166  # Siegmund's correction: twice -zeta(1/2)/sqrt(2 pi) = 0.583, the mean overshoot
DT = 0.1


def siegmund_arl(d: float, h: float) -> float:
    """Mean run length of a one-sided CUSUM whose increments have mean ``d`` (after the reference value)."""
    b = h + OVERSHOOT
    return (np.exp(-2.0 * d * b) + 2.0 * d * b - 1.0) / (2.0 * d * d)


def first_alarm(det: ChangeDetector, z: np.ndarray):
    """Feed the rows of ``z`` (n, m) at t = k DT until the first alarm: (k, alarms), or (None, [])."""
    for k, row in enumerate(z):
        alarms = det.update(k * DT, row)
        if alarms:
            return k, alarms
    return None, []


# ------------------------------------------------------------------------------------------- CUSUM, no change
def test_white_innovations_raise_no_alarm_with_the_default_policy():
    """kappa = 0.25, h = 25: Siegmund's in-control run length is 3.9e6 samples a side (1.9e6 two-sided), so
    20 000 component-samples alarm with probability below 20 000 / 1.9e6 ~ 1 % (a run length is at least
    geometric in the tail: P(alarm by N) <= N / ARL for a CUSUM started at zero)."""
    p = DetectionPolicy()
    arl0 = 1.0 / (2.0 / siegmund_arl(-p.drift, p.threshold))
    assert 1.5e6 < arl0 < 2.5e6  # the module's "about 2e6 samples per component"
    m, n = 4, 5000
    assert m * n / arl0 < 0.02
    det = ChangeDetector(m, p.drift, p.threshold)
    z = np.random.default_rng(11).standard_normal((n, m))
    k, alarms = first_alarm(det, z)
    assert k is None and alarms == []
    assert np.all(det.g >= 0.0) and np.all(det.g <= p.threshold)


def test_the_false_alarm_rate_of_a_low_threshold_matches_siegmund():
    """kappa = 0.5, h = 3: a two-sided in-control run length of 59.3 samples (Siegmund); 20 components for
    3000 samples, each restarted at its alarm, give about 1000 alarms: the renewal estimate (samples per
    alarm) has a standard error of about 1/sqrt(1000) = 3 %."""
    kappa, h, m, n = 0.5, 3.0, 20, 3000
    expected = 1.0 / (2.0 / siegmund_arl(-kappa, h))
    det = ChangeDetector(m, kappa, h)
    rng = np.random.default_rng(7)
    alarms = 0
    for k in range(n):
        for a in det.update(k * DT, rng.standard_normal(m)):
            alarms += 1
            det.reset(a.component)
    assert m * n / alarms == pytest.approx(expected, rel=0.10)


# ------------------------------------------------------------------------------------------- CUSUM, a step
def test_a_noiseless_step_gives_the_closed_form_delay_onset_and_size():
    """z = 0, then delta from sample k0: g grows by delta - kappa a sample, so the alarm comes at the
    (floor(h / (delta - kappa)) + 1)-th sample of the step; the likeliest onset is k0 exactly (zeros before it
    add samples, not sum) and the size is delta."""
    p = DetectionPolicy()
    delta, k0 = 2.0, 50
    z = np.zeros((200, 2))
    z[k0:, 0] = delta
    k, alarms = first_alarm(ChangeDetector(2, p.drift, p.threshold), z)
    assert k == k0 + int(np.floor(p.threshold / (delta - p.drift)))  # 15th sample of the step: k0 + 14
    (a,) = alarms
    assert a.component == 0
    assert a.onset == pytest.approx(k0 * DT, abs=1e-12)
    assert a.time == pytest.approx(k * DT, abs=1e-12)
    assert a.shift == pytest.approx(delta, rel=1e-12)


@pytest.mark.parametrize("delta", [2.0, -2.0])
def test_a_step_in_white_innovations_is_detected_on_its_side_located_and_sized(delta):
    """A step of 2 sigmas in component 1 of 3 at sample 400 (seeded). Wald / Siegmund: the mean delay is
    ARL(2 - 0.25) = 14.8 samples with a first-passage standard deviation sqrt(b / d^3) = 2.2, so an alarm
    within ARL + 4.5 sd (24.6 samples); a negative step alarms on the lower side (g^-) with a negative size.
    The GLR onset lies within a few samples of the change (Hinkley's change-point error has a scale of
    1/delta^2 = 0.25 sample; 5 samples allows its tail), and the size is the mean of z from that onset:
    within 3.5 standard errors 1/sqrt(n) of delta (its selection by the alarm biases it up a little)."""
    p = DetectionPolicy()
    k0, d = 400, abs(delta) - p.drift
    z = np.random.default_rng(2026).standard_normal((800, 3))
    z[k0:, 1] += delta
    det = ChangeDetector(3, p.drift, p.threshold)
    k, alarms = first_alarm(det, z)
    assert k is not None and k >= k0, "no alarm before the change"
    (a,) = alarms
    assert a.component == 1
    delay = k - k0 + 1  # samples of the step seen at the alarm
    sd = np.sqrt((p.threshold + OVERSHOOT) / d**3)
    assert delay <= siegmund_arl(d, p.threshold) + 4.5 * sd
    side, other = (0, 1) if delta > 0 else (1, 0)
    assert det.g[side, 1] > p.threshold and det.g[other, 1] <= p.threshold
    assert np.sign(a.shift) == np.sign(delta)
    k_onset = int(round(a.onset / DT))
    assert abs(k_onset - k0) <= 5
    assert a.time == pytest.approx(k * DT)
    n = k - k_onset + 1
    assert abs(a.shift - delta) <= 3.5 / np.sqrt(n)


@pytest.mark.parametrize("delta", [2.0, -2.0])
def test_over_many_seeds_the_delay_follows_wald_and_the_onset_is_unbiased(delta):
    """100 seeded runs of a 2-sigma step at sample 200: the mean delay is at most Siegmund's 14.8 samples
    (that is from g = 0; before a change g sits a little above zero, which only shortens it) and more than
    three quarters of it; the median onset error is zero and at least 80 % of the onsets are within
    3 samples of the change; the size's error in standard errors has a median within 0.5 of zero."""
    p = DetectionPolicy()
    k0, d = 200, abs(delta) - p.drift
    delays, onset_err, size_err = [], [], []
    for seed in range(100):
        z = np.random.default_rng(seed).standard_normal((400, 1))
        z[k0:, 0] += delta
        k, (a,) = first_alarm(ChangeDetector(1, p.drift, p.threshold), z)
        assert k >= k0
        k_onset = int(round(a.onset / DT))
        delays.append(k - k0 + 1)
        onset_err.append(k_onset - k0)
        size_err.append((a.shift - delta) * np.sqrt(k - k_onset + 1))
    arl1 = siegmund_arl(d, p.threshold)
    assert 0.75 * arl1 <= np.mean(delays) <= arl1
    assert np.median(onset_err) == 0
    assert np.mean(np.abs(onset_err) <= 3) >= 0.80
    assert abs(np.median(size_err)) <= 0.5


def test_a_reset_component_starts_over_and_the_others_keep_their_statistic():
    det = ChangeDetector(2, 0.25, 25.0)
    for k in range(5):
        det.update(k * DT, [3.0, 3.0])
    assert det.g[0] == pytest.approx([5 * 2.75, 5 * 2.75])
    det.reset(0)
    assert det.g[0, 0] == 0.0 and det.g[0, 1] == pytest.approx(5 * 2.75)
    # a component left out of an update keeps its statistic
    det.update(0.5, [1.0], components=[0])
    assert det.g[0] == pytest.approx([0.75, 5 * 2.75])


# ------------------------------------------------------------------------------------------- validity monitor
def independent_flag(nis, dofs, t, window_n, probability, validity_time):
    """The monitor's rule computed apart: rolling sums of NIS and dof over ``window_n`` samples, held against
    the upper chi-square quantile of probability (1 - probability) / 2; the first sample at which the sum has
    been above it without a break for ``validity_time``: (since, time), or None."""
    c = np.concatenate([[0.0], np.cumsum(nis)])
    cd = np.concatenate([[0], np.cumsum(dofs)])
    since = None
    for k in range(window_n - 1, len(nis)):
        s, dof = c[k + 1] - c[k + 1 - window_n], cd[k + 1] - cd[k + 1 - window_n]
        if s > chi2.ppf(1.0 - 0.5 * (1.0 - probability), dof):
            since = t[k] if since is None else since
            if t[k] - since >= validity_time - 1e-9:
                return since, t[k]
        else:
            since = None
    return None


@pytest.mark.parametrize("dofs", [(3,), (7, 6)])
def test_the_band_is_the_two_sided_chi_square_quantile_of_the_windows_dof(dofs):
    """Constant NIS just below and just above the upper quantile of the window's summed dof (a sensor whose
    dof changes, an encoder isolated, sums its own); with validity_time 0 a sum above the band flags at
    once."""
    policy = DetectionPolicy(validity_window=3.0, validity_probability=0.99, validity_time=0.0)
    n = 30
    dof_seq = np.resize(np.array(dofs), n)
    q = chi2.isf(0.005, dof_seq.sum())
    for factor, flagged in ((1.0 - 1e-6, False), (1.0 + 1e-6, True)):
        mon = ValidityMonitor(policy, DT)
        out = [mon.update("s", k * DT, q * factor / n, int(dof_seq[k])) for k in range(n)]
        assert all(o is None for o in out[:-1])  # nothing before the window is full
        assert (out[-1] is not None) == flagged
        if flagged:
            assert out[-1].since == out[-1].time == pytest.approx((n - 1) * DT) and out[-1].side == "high"
            assert mon.flags == [out[-1]]


def test_chi_square_nis_over_a_long_run_is_never_flagged():
    """NIS ~ chi2(3) for 5000 samples against the default policy (300-sample window, 0.999 two-sided band,
    20 s). A flag needs the window sums ending 200 samples apart both above the 0.9995 quantile (z = 3.29);
    they share 100 of their 300 samples (correlation 1/3), and the bivariate normal tail there is 6.5e-6
    (the sums of 900 dof are near normal), so the probability of a flag in the run is below
    5000 x 6.5e-6 = 3 %."""
    p = DetectionPolicy()
    z, rho = norm.isf(0.5 * (1.0 - p.validity_probability)), 1.0 / 3.0
    joint, _ = quad(lambda x: norm.pdf(x) * norm.sf((z - rho * x) / np.sqrt(1.0 - rho**2)), z, np.inf)
    assert 3e-6 < joint < 1e-5
    n = 5000
    assert n * joint < 0.05
    nis = np.random.default_rng(5).chisquare(3, n)
    mon = ValidityMonitor(p, DT)
    assert all(mon.update("gyro", k * DT, x, 3) is None for k, x in enumerate(nis))
    assert mon.flags == []


def test_nis_three_times_too_large_is_flagged_within_a_window_and_after_the_validity_time():
    """chi2(3) NIS, multiplied by 3 from t0 = 100 s: the windowed sum (mean 900, sd 42) leaves its band once
    about 25 inflated samples are in (each adds 6), well within one 30 s window of t0; the flag comes
    validity_time (20 s) after that, within one sample, and agrees with the rule computed apart. Too small a
    NIS (the filter pessimistic) is not flagged."""
    p = DetectionPolicy()
    n, t0 = 3000, 100.0
    t = np.arange(n) * DT
    nis = np.random.default_rng(9).chisquare(3, n)
    nis[t >= t0 - 1e-9] *= 3.0
    mon = ValidityMonitor(p, DT)
    flags = [f for k in range(n) if (f := mon.update("accelerometer", t[k], nis[k], 3)) is not None]
    assert len(flags) == 1 and mon.flags == flags  # flagged once
    f = flags[0]
    assert f.sensor == "accelerometer" and f.side == "high"
    assert t0 <= f.since <= t0 + p.validity_window
    assert abs(f.time - (f.since + p.validity_time)) <= DT + 1e-9
    window_n = int(round(p.validity_window / DT))
    since, time = independent_flag(nis, np.full(n, 3), t, window_n, p.validity_probability, p.validity_time)
    assert f.since == pytest.approx(since) and abs(f.time - time) <= DT + 1e-9
    low = ValidityMonitor(p, DT)
    nis_low = np.where(t >= t0 - 1e-9, nis / 9.0, nis)  # a third of the chi-square's
    assert all(low.update("accelerometer", t[k], nis_low[k], 3) is None for k in range(n)) and low.flags == []


class KeptWindowRule:
    """The validity monitor's rule computed apart, for one sensor, on a plain list of the samples kept: the last
    ``window_n`` ever fed, less those a rewind dropped (the window refills after a rewind), and the flags
    raised after the rewind's time forgotten."""

    def __init__(self, policy: DetectionPolicy, window_n: int):
        self.p, self.n = policy, window_n
        self.bound = {d: chi2.isf(0.5 * (1.0 - policy.validity_probability), d) for d in range(1, 4 * window_n)}
        self.kept, self.since, self.flags = [], None, []

    def rewind(self, t_r: float) -> None:
        while self.kept and self.kept[-1][0] > t_r:
            self.kept.pop()
        if self.since is not None and self.since > t_r:
            self.since = None
        self.flags = [f for f in self.flags if f[1] <= t_r]

    def update(self, t: float, nis: float, dof: int):
        """The new flag (since, time), or None."""
        self.kept = (self.kept + [(t, nis, dof)])[-self.n:]
        if len(self.kept) < self.n:
            return None
        if sum(x for _, x, _ in self.kept) <= self.bound[sum(d for _, _, d in self.kept)]:
            self.since = None
            return None
        self.since = t if self.since is None else self.since
        if t - self.since >= self.p.validity_time and not self.flags:
            self.flags.append((self.since, t))
            return self.flags[-1]
        return None


def test_rewinds_keep_the_windowed_sums_and_flags_of_the_samples_kept():
    """The supervisor rewinds the monitor (drops every sample after a time) and feeds it the re-processed
    samples again. Against the rule computed apart on a plain list of the samples kept (the last ``window_n``
    ever fed, less those dropped: the window refills after a rewind; the flags raised after the rewind's time
    forgotten): the same flags, at the same samples, with the same onsets, over 40 seeded rewinds (some back
    past a flag) of a NIS that wanders in and out of the band. A decision at the band's edge would show a sum
    that is not the left-to-right sum of the window's NIS."""
    p = DetectionPolicy(validity_window=2.0, validity_time=1.0)
    rule = KeptWindowRule(p, int(round(p.validity_window / DT)))
    rng = np.random.default_rng(19)
    mon = ValidityMonitor(p, DT)
    k, n_rewinds, raised = 0, 0, 0
    while k < 3000:
        # go back up to 3 s and feed those instants again: at random, and soon after a flag (as after an alarm)
        if k > 50 and (rng.random() < 0.02 or (rule.flags and k * DT - rule.flags[-1][1] == pytest.approx(0.5))):
            k = max(k - int(rng.integers(1, 30)), 0)
            mon.rewind(k * DT)
            rule.rewind(k * DT)
            n_rewinds += 1
        t = (k + 1) * DT
        dof = int(rng.integers(2, 4))
        nis = float((1.0 + 0.6 * np.sin(2.0 * np.pi * t / 40.0)) * rng.chisquare(dof))  # in and out of the band
        got, want = mon.update("s", t, nis, dof), rule.update(t, nis, dof)
        assert (None if got is None else (got.since, got.time)) == want, (k, got, want)
        raised += got is not None
        k += 1
    assert n_rewinds >= 40 and raised >= 3 and [(f.since, f.time) for f in mon.flags] == rule.flags


def test_the_running_window_sum_decides_as_the_left_to_right_sum_even_at_the_band_edge():
    """The monitor's window keeps its NIS sum running (``_Window``) but must decide as the left-to-right sum of
    the samples kept (``sum``, what the monitor always computed). Over 20 000 seeded steps (chi-square NIS
    with spikes of 1e8, tiny values, an infinity and a NaN now and then, and rewinds), against bounds drawn
    at random, equal to that sum and one ulp either side of it: every decision is the left-to-right sum's;
    and the running sum did drift from it (the guard is needed) while deciding most of the random bounds."""
    from postcapture.estimation.detect import _Window

    n = 50
    rng = np.random.default_rng(2019)
    window, kept = _Window(n), []
    drifted = fast = 0
    for k in range(20000):
        t = k * DT
        if k > n and rng.random() < 0.02:
            t_r = t - DT * int(rng.integers(1, 20))
            window.drop_after(t_r)
            while kept and kept[-1][0] > t_r:
                kept.pop()
            continue
        u = rng.random()
        x = 1e8 * rng.random() if u < 0.01 else 1e-8 * rng.random() if u < 0.02 else float(rng.chisquare(3))
        x = np.inf if u > 0.9995 else np.nan if u > 0.999 else x
        window.append(t, x, 3)
        kept = (kept + [(t, x)])[-n:]
        exact = sum(v for _, v in kept)
        assert len(window) == len(kept) and window.dof_sum == 3 * len(kept)
        drifted += window.running != exact and np.isfinite(exact)
        bound = float(rng.uniform(0.0, 2.0 * exact)) if np.isfinite(exact) and exact > 0.0 else 1.0
        ops = window._ops
        assert window.exceeds(bound) == (exact > bound), (k, bound, exact)
        fast += window._ops == ops and ops > 0  # decided without summing again
        for b in (exact, np.nextafter(exact, -np.inf), np.nextafter(exact, np.inf)):
            if np.isfinite(b):
                assert window.exceeds(b) == (exact > b), (k, b, exact)
    assert drifted > 100 and fast > 10000
