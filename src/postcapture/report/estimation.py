"""Tables and figures of the main job (plain arrays in, text and matplotlib figures out).

Figures follow the reference: the fourth quaternion component estimated vs true (its figure 4a), the
attitude error with the filter's 3-sigma envelope (4b), the mass estimate of every case vs the truth
(5 and 6), plus the mass error on a log scale against the Cramer-Rao bound.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

__all__ = ["results_table", "quaternion_figure", "attitude_error_figure", "mass_figure", "mass_error_figure"]

ARCSEC = np.pi / (180.0 * 3600.0)


def _fmt(value, spec: str, none: str = "never") -> str:
    if value is None:
        return none
    if isinstance(value, float) and not np.isfinite(value):
        return "-"
    return format(value, spec)


def results_table(summary: dict) -> str:
    """The main job's table (one line per case) from its JSON summary."""
    lines = [
        f"scenario {summary['scenario']}, profile {summary['profile']}, plant {summary.get('plant', 'native')}, "
        f"{summary['duration_s']:g} s; "
        f"true mass {summary['true_mass_kg']:.1f} kg, filters start at {summary['initial_mass_kg']:.1f} kg",
        f"{'case':<22}{'mass err':>10}{'3 sigma':>9}{'1% at':>8}{'0.1% at':>9}{'att RMS':>10}{'steady':>9}"
        f"{'in 3s':>7}{'NEES':>9}{'NIS':>6}{'wall':>7}",
        f"{'':<22}{'(kg)':>10}{'(kg)':>9}{'(s)':>8}{'(s)':>9}{'(arcsec)':>10}{'(arcsec)':>9}{'':>7}{'(3)':>9}{'(3)':>6}{'(s)':>7}",
    ]
    for name, m in summary["cases"].items():
        note = "" if m.get("success", True) else f"   {m.get('message', 'diverged')}"
        three_sigma = None if m["mass_sigma_kg"] is None else 3 * m["mass_sigma_kg"]
        lines.append(
            f"{name:<22}{_fmt(m['mass_error_kg'], '.2f', '-'):>10}{_fmt(three_sigma, '.2f', '-'):>9}"
            f"{_fmt(m['settle_1pct_s'], '.1f'):>8}{_fmt(m['settle_01pct_s'], '.1f'):>9}"
            f"{_fmt(m['attitude_rms_arcsec'], '.3g', '-'):>10}{_fmt(m['attitude_rms_steady_arcsec'], '.3g', '-'):>9}"
            f"{_fmt(m['inside_3sigma'], '.1%', '-'):>7}{_fmt(m['nees_mean'], '.3g', '-'):>9}"
            f"{_fmt(m['nis_mean'], '.2f', '-'):>6}{m['wall_s']:>7.1f}{note}"
        )
    crlb = summary.get("crlb_mass_kg")
    if crlb:
        lines.append(
            f"Cramer-Rao bound on the mass (1 sigma): {crlb['all_sensors']:.3g} kg with every sensor, "
            f"{crlb['accelerations_only']:.3g} kg from the accelerations alone (what a dual mass filter sees)"
        )
    f = summary.get("farrenkopf")
    if f:
        for name, v in f.items():
            if isinstance(v, dict):
                ratios = ", ".join(f"{r:.2f}" for r in v["ratio"])
                lines.append(f"{name}: steady attitude error / Farrenkopf's bound per sensor axis: {ratios}")
    n = summary.get("noise", {})
    if n:
        lines.append(
            f"noise: star tracker {n['star_tracker_cross_arcsec']:.3g}/{n['star_tracker_roll_arcsec']:.3g} arcsec "
            f"(cross/roll), gyro ARW {n['gyro_arw_rad_sqrt_s']:.2g} rad/sqrt(s), accelerometer "
            f"{n['accelerometer_m_s2']:.2g} m/s^2 (bias {n['accelerometer_bias_m_s2']:.2g}), joints "
            f"{n['joint_acceleration_rad_s2']:.2g} rad/s^2, all at {n['rate_hz']:g} Hz"
        )
    lines.append(f"total wall time {summary['wall_s']:.1f} s (truth {summary['truth_wall_s']:.1f} s)")
    return "\n".join(lines)


def quaternion_figure(t, q_true, estimates: dict) -> Figure:
    """Fourth quaternion component (z), estimated vs true (reference figure 4a)."""
    fig = Figure(figsize=(8, 4), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(t, q_true[3], "k", lw=2.0, label="true")
    for name, q in estimates.items():
        ax.plot(t, q[3], lw=1.0, label=name)
    ax.set(xlabel="time (s)", ylabel="$q_z$ of $q_{BN}$ (-)", title="Fourth quaternion component")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def attitude_error_figure(t, error, sigma, name: str) -> Figure:
    """Attitude error per body axis with the filter's 3-sigma envelope (reference figure 4b)."""
    fig = Figure(figsize=(8, 6), layout="constrained")
    for i, axis in enumerate("xyz"):
        ax = fig.add_subplot(3, 1, i + 1)
        ax.plot(t, error[i] / ARCSEC, lw=0.7, label="error")
        ax.plot(t, 3 * sigma[i] / ARCSEC, "r--", lw=0.8, label="±3σ")
        ax.plot(t, -3 * sigma[i] / ARCSEC, "r--", lw=0.8)
        ax.set_ylabel(f"{axis} (arcsec)")
        ax.grid(alpha=0.3)
        late = t >= t[0] + 0.1 * (t[-1] - t[0])  # scale on the run after the initial transient
        values = np.abs(np.concatenate([error[i][late], 3 * sigma[i][late]]))
        values = values[np.isfinite(values)]  # a diverged filter leaves NaN
        if values.size and values.max() > 0:
            span = values.max() / ARCSEC
            ax.set_ylim(-2.0 * span, 2.0 * span)
        if i == 0:
            ax.set_title(f"Attitude error, {name}")
            ax.legend(fontsize=8, loc="upper right")
    ax.set_xlabel("time (s)")
    return fig


def mass_figure(t, true_mass: float, estimates: dict, sigmas: dict) -> Figure:
    """Mass estimate of every case with its 3-sigma band, and the truth (reference figures 5-6)."""
    fig = Figure(figsize=(8, 5), layout="constrained")
    ax = fig.add_subplot()
    ax.axhline(true_mass, color="k", lw=2.0, label="true")
    for i, (name, m) in enumerate(estimates.items()):
        # dashed for every other case: dual schemes sharing a mass filter draw the same curve
        line, = ax.plot(t, m, lw=1.2, ls="-" if i % 2 == 0 else "--", label=name)
        s = sigmas.get(name)
        if s is not None:
            band = np.where(3 * s < 150.0, 3 * s, np.nan)  # a band wider than the plot hides the rest
            ax.fill_between(t, m - band, m + band, color=line.get_color(), alpha=0.12)
    ax.set(xlabel="time (s)", ylabel="target mass (kg)", title="Mass estimates (bands: ±3σ where under 150 kg)")
    lo = min(np.nanmin(m) for m in estimates.values())
    hi = max(np.nanmax(m) for m in estimates.values())
    pad = 0.1 * (hi - lo + 1.0)
    ax.set_ylim(max(lo - pad, true_mass - 600), min(hi + pad, true_mass + 600))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def mass_error_figure(t, true_mass: float, estimates: dict, crlb_kg: float | None) -> Figure:
    """Absolute mass error on a log scale, with the Cramer-Rao bound."""
    fig = Figure(figsize=(8, 4), layout="constrained")
    ax = fig.add_subplot()
    for name, m in estimates.items():
        ax.semilogy(t, np.abs(m - true_mass) + 1e-6, lw=1.0, label=name)
    if crlb_kg:
        ax.axhline(crlb_kg, color="k", ls=":", label=f"CRLB at the end ({crlb_kg:.2g} kg)")
    ax.axhline(0.01 * true_mass, color="grey", ls="--", lw=0.8, label="1 %")
    ax.axhline(0.001 * true_mass, color="grey", ls="-.", lw=0.8, label="0.1 %")
    ax.set(xlabel="time (s)", ylabel="|mass error| (kg)", title="Mass error")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return fig
