"""Mass figures of the main job, one panel per filter model as the reference's figure 5 (a)/(b).

- :func:`mass_estimates_figure` (the reference's figures 5 and 6b): every case's estimate with its
  3-sigma band over the whole run (its two edges as dotted lines in the case's colour, so that a band
  wider than the axes still shows where it ends), and the truth.
- :func:`mass_error_figure`: the signed error (linear), and its moving RMS on a log scale, so that
  converged errors read as decades without the spikes of ``|error|`` at every zero crossing.

Both read a results dataset (``postcapture.studies.results.to_dataset``).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from postcapture.report.layout import (
    RMS_WINDOW_S,
    case_label,
    divergence_time,
    identical_to,
    last_before,
    model_groups,
    model_title,
    moving_rms,
    subtitle,
)
from postcapture.report.style import (
    TRUTH_STYLE,
    artist_gid,
    band_edges,
    case_styles,
    legend_outside,
    mark_divergence,
    new_figure,
    panel_title,
)

__all__ = ["mass_estimates_figure", "mass_error_figure"]


def mass_estimates_figure(ds) -> Figure:
    """Mass estimates with their 3-sigma bands and the truth, one panel per filter model.

    Parameters
    ----------
    ds : xarray.Dataset
        A main-job results dataset.

    Returns
    -------
    matplotlib.figure.Figure
    """
    groups = model_groups(ds)
    t = ds["time"].values
    m_true = float(ds.attrs["true_mass_kg"])
    styles = case_styles(str(c) for c in ds["case"].values)
    same = identical_to(ds, "mass_est")
    fig, axes = new_figure(1, len(groups), time=t, width=4.8 * len(groups) + 1.0, row_height=3.8)
    for col, (model, cases) in enumerate(groups):
        ax = axes[0, col]
        ax.axhline(m_true, **TRUTH_STYLE)
        finite = [m_true]
        for case in cases:
            style = styles[case]
            m = ds["mass_est"].sel(case=case).values
            s = ds["mass_sigma"].sel(case=case).values
            if case not in same:  # a case drawn over an identical one adds no second band
                band_edges(ax, t, m - 3 * s, m + 3 * s, style, case, label="±3σ of each filter (dotted, its colour)")
            ax.plot(t, m, label=case_label(case, same), gid=artist_gid(case, "line"), **style.line())
            finite.extend(m[np.isfinite(m)].tolist())
            last = np.nonzero(np.isfinite(m) & np.isfinite(s))[0]
            if last.size and case not in same:  # the final band's edges are in view (the early ones are wide)
                finite += [m[last[-1]] - 3 * s[last[-1]], m[last[-1]] + 3 * s[last[-1]]]
            t_div = divergence_time(ds, case)
            if t_div is not None:
                mark_divergence(ax, t_div, last_before(t, m, t_div), style, case)
        lo, hi = min(finite), max(finite)
        pad = 0.08 * (hi - lo) + 1.0
        ax.set_ylim(lo - pad, hi + pad)
        ax.ticklabel_format(axis="y", useOffset=False, style="plain")
        panel_title(ax, col, model_title(model))
        ax.set_xlabel("time (s)")
    axes[0, 0].set_ylabel("target mass (kg)")
    fig.suptitle(f"Target mass estimates and each filter's ±3σ (dotted edges)\n{subtitle(ds)}", fontsize=11)
    legend_outside(fig)
    return fig


def mass_error_figure(ds) -> Figure:
    """Signed mass error (estimate minus truth), and its moving RMS on a log scale, per filter model.

    Parameters
    ----------
    ds : xarray.Dataset
        A main-job results dataset.

    Returns
    -------
    matplotlib.figure.Figure
        Top row: the signed error (kg, linear); bottom row: its 10 s trailing RMS (kg, log), where
        converged estimators separate by decades. Grey lines mark 1 % and 0.1 % of the true mass.
    """
    groups = model_groups(ds)
    t = ds["time"].values
    m_true = float(ds.attrs["true_mass_kg"])
    styles = case_styles(str(c) for c in ds["case"].values)
    same = identical_to(ds, "mass_est")
    errors = {str(c): ds["mass_est"].sel(case=c).values - m_true for c in ds["case"].values}
    start = max((abs(e[np.isfinite(e)][0]) for e in errors.values() if np.isfinite(e).any()), default=1.0)
    fig, axes = new_figure(2, len(groups), time=t, width=4.8 * len(groups) + 1.0, row_height=2.9, sharey="row")
    for col, (model, cases) in enumerate(groups):
        ax_e, ax_r = axes[0, col], axes[1, col]
        ax_e.axhline(0.0, color="black", linewidth=0.8, zorder=1.0)
        for frac, ls, text in ((0.01, "--", "1 % of the true mass"), (0.001, "-.", "0.1 % of the true mass")):
            for sign in (1, -1):
                ax_e.axhline(sign * frac * m_true, color="0.45", linestyle=ls, linewidth=0.8, zorder=1.0)
            ax_r.axhline(frac * m_true, color="0.45", linestyle=ls, linewidth=0.8, zorder=1.0, label=text)
        for case in cases:
            style = styles[case]
            e = errors[case]
            rms = moving_rms(t, e, RMS_WINDOW_S)
            ax_e.plot(t, e, label=case_label(case, same), gid=artist_gid(case, "line"), **style.line())
            ax_r.plot(t, rms, gid=artist_gid(case, "line"), **style.line())
            t_div = divergence_time(ds, case)
            if t_div is not None:
                mark_divergence(ax_e, t_div, last_before(t, e, t_div), style, case)
                mark_divergence(ax_r, t_div, last_before(t, rms, t_div), style, case, text=False)
        ax_e.set_ylim(-1.15 * start, 1.15 * start)
        ax_r.set_yscale("log")
        panel_title(ax_e, col, model_title(model))
        ax_r.set_xlabel("time (s)")
    axes[0, 0].set_ylabel("estimate − truth (kg)")
    axes[1, 0].set_ylabel(f"error, {RMS_WINDOW_S:g} s RMS (kg)")
    fig.suptitle(f"Target mass error\n{subtitle(ds)}", fontsize=11)
    legend_outside(fig)
    return fig
