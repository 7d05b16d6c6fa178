"""Tables and figures of a Monte Carlo campaign (its summary dict and its xarray Dataset in; text and figures out).

- ``campaign_final_errors``: each run's final mass error with the filter's own 3-sigma bar, one panel per
  case, against +-3 times the Cramer-Rao bound (what any estimator can claim); runs whose error lies
  outside their 3 sigma are marked with a cross.
- ``campaign_nees``: the NEES averaged over the runs at each instant, mass (1 degree of freedom) and
  attitude (3), against the two-sided 95 % chi-square band for that many runs (its edges dotted) and the
  expected value (dashed), on a log axis labelled with plain numbers.
"""

from __future__ import annotations

import textwrap

import numpy as np
from matplotlib.figure import Figure

from postcapture.core.consistency import run_averaged_nees
from postcapture.report.style import artist_gid, case_style, legend_outside

__all__ = ["campaign_table", "campaign_figures"]


def _num(value, spec: str, width: int) -> str:
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "-".rjust(width)
    return format(value, spec).rjust(width)


def campaign_table(summary: dict) -> str:
    """The campaign's table, at most 80 columns wide."""
    kind = "dispersed truths" if summary.get("dispersed") else "one truth"
    any_case = next(iter(summary["cases"].values()), {})
    lo1, hi1 = any_case.get("nees_band", (float("nan"),) * 2)
    lines = [
        f"campaign '{summary.get('scenario')}', {summary.get('profile')} profile: {summary['runs']} runs, {kind}",
        f"{'case':<16}{'mean':>8}{'std':>8}{'RMS':>8}{'3s sd':>8}{'in 3s':>7}{'NEES':>9}{'att NEES':>10}{'div':>5}",
        f"{'':<16}{'(kg)':>8}{'(kg)':>8}{'(kg)':>8}{'(kg)':>8}{'':>7}{'(1)':>9}{'(3)':>10}{'':>5}",
    ]
    for name, c in summary["cases"].items():
        sd = None if c.get("mass_sigma_mean_kg") is None else 3.0 * c["mass_sigma_mean_kg"]
        lines.append(
            f"{name[:15]:<16}{_num(c['mass_error_mean_kg'], '.1f', 8)}{_num(c['mass_error_std_kg'], '.1f', 8)}"
            f"{_num(c['mass_error_rms_kg'], '.1f', 8)}{_num(sd, '.1f', 8)}{_num(c['inside_3sigma_fraction'], '.0%', 7)}"
            f"{_num(c['nees_mean'], '.3g', 9)}{_num(c['attitude_nees_mean'], '.3g', 10)}{c['diverged_runs']:>5d}"
        )
    notes = [f"Every run counts: mean, std and RMS of the final mass error over all {summary['runs']} runs (a "
             "diverged run with its last estimate); 'in 3s': the share of all runs whose final error lies inside "
             "their own filter's 3 sigma (a diverged run counts as outside); NEES averaged over all runs."]
    for n, c in summary["cases"].items():
        if c.get("diverged_runs"):
            notes.append(f"{n}: diverged in {c['diverged_runs']} of {summary['runs']} runs; over the others, mass "
                         f"error RMS {_num(c.get('mass_error_rms_survivors_kg'), '.1f', 0)} kg, NEES "
                         f"{_num(c.get('nees_mean_survivors'), '.3g', 0)} (mass), "
                         f"{_num(c.get('attitude_nees_mean_survivors'), '.3g', 0)} (attitude).")
        if c.get("runs_without_estimate"):
            notes.append(f"{n}: {c['runs_without_estimate']} runs ended without any mass estimate (left out of the "
                         "mean, std and RMS, counted outside 3 sigma).")
    for n, c in summary["cases"].items():
        if c.get("com_error_rms_m") is not None:
            text = (f"{n}: final error RMS of the target's CoM {c['com_error_rms_m']:.3g} m, of its principal "
                    f"inertia {c['inertia_error_rms_kgm2']:.3g} kg m^2")
            if c.get("com_inside_3sigma_fraction") is not None:
                text += (f"; inside the filter's 3 sigma: {c['com_inside_3sigma_fraction']:.0%} of CoM components, "
                         f"{c['inertia_inside_3sigma_fraction']:.0%} of inertia components")
            notes.append(text + ".")
    band = f"95 % NEES bands for {summary['runs']} runs: mass [{lo1:.2f}, {hi1:.2f}]"
    if any_case.get("attitude_nees_band"):
        band += ", attitude [{:.2f}, {:.2f}]".format(*any_case["attitude_nees_band"])
    notes.append(band + "; '3s sd': the filters' mean 3 sigma of the mass.")
    if any_case.get("crlb_kg"):
        text = f"Cramer-Rao bound on the mass, every sensor: {any_case['crlb_kg']:.3g} kg with the declared parameters unknown"
        if any_case.get("crlb_known_model_kg"):
            text += f", {any_case['crlb_known_model_kg']:.3g} kg with a known model"
        notes.append(text + ".")
    if summary.get("resumed_runs"):
        notes.append(f"Resumed: {summary['resumed_runs']} runs were loaded from an interrupted campaign.")
    notes.append(f"Wall time {summary['wall_s']:.1f} s.")
    for note in notes:
        lines += textwrap.wrap(note, 80, subsequent_indent="  ")
    return "\n".join(lines)


def _plain_log_ticks(ax) -> None:
    """Log axis labelled with plain numbers at 1-2-5 steps (0.5, 1, 2, 5, 10), no minor labels."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.yaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0), numticks=12))
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(NullFormatter())


def _title(summary: dict, what: str) -> str:
    truth = summary.get("truth")
    kind = ("dispersed truths drawn from the priors" if summary.get("dispersed")
            else f"one truth: {'the nominal scenario' if truth in (None, 'nominal') else truth}")
    seeds = f", seeds ({summary['seed']}, r)" if summary.get("seed") is not None else ""
    return (f"{what}\nscenario {summary.get('scenario')}, {summary.get('profile')} profile, {summary['runs']} runs; "
            f"{kind}{seeds}")


def campaign_figures(ds, summary: dict) -> dict:
    """``{stem: Figure}`` of a campaign (see the module docstring)."""
    from postcapture.io.netcdf import labelled

    ds = labelled(ds)
    cases = [str(c) for c in ds["case"].values]
    n_c = len(cases)
    runs = ds["run"].values
    t = ds["time"].values

    fig = Figure(figsize=(8, 1.0 + 2.2 * n_c), layout="constrained")
    for j, case in enumerate(cases):
        ax = fig.add_subplot(n_c, 1, j + 1)
        err = ds["mass_error"].values[:, j, :]
        sig = ds["mass_sigma"].values[:, j, :]
        last = np.array([np.nonzero(np.isfinite(e))[0][-1] if np.isfinite(e).any() else 0 for e in err])
        e_f = err[np.arange(len(runs)), last]
        s_f = sig[np.arange(len(runs)), last]
        inside = (np.abs(e_f) <= 3.0 * s_f) & ~np.isfinite(ds["diverged_at"].values[:, j])
        colour = case_style(case).color
        for mask, fmt, label in ((inside, "o", "inside its 3σ"), (~inside, "X", "outside its 3σ")):
            if mask.any():
                ax.errorbar(runs[mask], e_f[mask], yerr=3.0 * s_f[mask], fmt=fmt, ms=3 if fmt == "o" else 6, lw=0.8,
                            capsize=2, color=colour, mec="black" if fmt == "X" else colour,
                            label=f"{case}: {label} ({int(mask.sum())})")
        ax.axhline(0.0, color="0.3", lw=0.8)
        c = summary["cases"][case]
        crlb = c.get("crlb_kg")
        if crlb:  # what any estimator can claim with this model error: +-3 CRLB, as edges
            for sign in (-1, 1):
                ax.axhline(sign * 3.0 * crlb, color="0.25", linestyle=(0, (6.0, 3.0)), lw=1.0,
                           label=f"±3 × Cramer-Rao bound ({3.0 * crlb:.3g} kg)" if sign > 0 else "_nolegend_")
        title = f"{case}: {c['inside_3sigma_fraction']:.0%} of the runs inside their 3σ"
        if c["mass_error_rms_kg"] is not None:
            title += f", RMS {c['mass_error_rms_kg']:.3g} kg"
        if c["diverged_runs"]:
            title += f", {c['diverged_runs']} diverged (last value before divergence shown)"
        ax.set_title(title, fontsize=9)
        ax.xaxis.get_major_locator().set_params(integer=True)
        ax.set_ylabel("final mass error (kg)")
        ax.grid(alpha=0.3)
    ax.set_xlabel("run")
    fig.suptitle(_title(summary, "Final mass error and the filter's ±3σ"), fontsize=10)
    legend_outside(fig)

    fig2 = Figure(figsize=(10, 1.0 + 2.2 * n_c), layout="constrained")
    for j, case in enumerate(cases):
        c = summary["cases"][case]
        stop = ds["diverged_at"].values[:, j]  # a diverged filter's NEES is left out from then on
        with np.errstate(invalid="ignore", divide="ignore"):
            m_nees = run_averaged_nees((ds["mass_error"].values[:, j, :] / ds["mass_sigma"].values[:, j, :]) ** 2, t, stop)
        a_nees = run_averaged_nees(ds["attitude_nees"].values[:, j, :], t, stop)
        for col, (values, band, label) in enumerate(((m_nees, c["nees_band"], "mass NEES (1)"),
                                                     (a_nees, c["attitude_nees_band"], "attitude NEES (3)"))):
            ax = fig2.add_subplot(n_c, 2, 2 * j + col + 1)
            ax.semilogy(t[1:], values[1:], color=case_style(case).color, linestyle=case_style(case).linestyle,
                        lw=1.0, label=f"{case}: mean over runs", gid=artist_gid(case, "line"))
            for edge in band:
                ax.axhline(edge, color="0.35", lw=0.9, linestyle=(0, (1.0, 1.5)),
                           label="95 % band of the mean (dotted)" if edge == band[0] else "_nolegend_")
            expected = 1.0 if col == 0 else 3.0  # the state's dimension
            ax.axhline(expected, color="0.1", lw=1.0, linestyle=(0, (6.0, 3.0)),
                       label="expected value (1 mass, 3 attitude)")
            _plain_log_ticks(ax)
            ax.set_title(f"{case}: {label}", fontsize=9)
            ax.grid(alpha=0.3, which="major")
            if j == n_c - 1:
                ax.set_xlabel("time (s)")
    fig2.suptitle(_title(summary, "NEES averaged over the runs"), fontsize=10)
    legend_outside(fig2)
    return {"campaign_final_errors": fig, "campaign_nees": fig2}
