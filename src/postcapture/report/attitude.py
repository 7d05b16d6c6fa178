"""Attitude figures of the main job: estimates against the truth, and errors against the filters' 3 sigma.

- :func:`attitude_estimates_figure` (the reference's figures 4a and 6a): the reference drew a quaternion
  component of every case over the truth; at any readable scale they coincide (the q_z row of the former
  figure carried no information), so this draws the attitude error angle of every case, where they
  separate, with each filter's own 3-sigma of it.
- :func:`attitude_error_figure` (the reference's figure 4b): one case's error per body axis within
  the filter's own 3-sigma envelope (its edges dotted in the case's colour).

Both read a results dataset (``postcapture.studies.results.to_dataset``). :func:`sign_continuous` and
:func:`align_to` make quaternion histories drawable (a quaternion and its negative are the same attitude;
the stored ``w >= 0`` convention jumps from +q to -q when w crosses zero).
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from postcapture.core.units import ARCSEC
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
    twins,
)
from postcapture.report.style import (
    BAND_EDGE,
    artist_gid,
    band_edges,
    case_styles,
    legend_outside,
    mark_divergence,
    new_figure,
    panel_title,
)

__all__ = ["sign_continuous", "align_to", "attitude_estimates_figure", "attitude_error_figure"]

def sign_continuous(q: np.ndarray) -> np.ndarray:
    """Flip the sign of quaternion samples (4, n) so that consecutive samples have a positive dot product."""
    q = np.array(q, dtype=float)
    dots = np.einsum("ik,ik->k", q[:, 1:], q[:, :-1])
    flips = np.concatenate([[1.0], np.cumprod(np.where(dots < 0.0, -1.0, 1.0))])
    return q * flips


def align_to(q: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Flip each sample of ``q`` (4, n) into the hemisphere of ``reference`` (4, n); NaN stays NaN."""
    q = np.array(q, dtype=float)
    dots = np.einsum("ik,ik->k", q, reference)
    return q * np.where(dots < 0.0, -1.0, 1.0)


def attitude_estimates_figure(ds) -> Figure:
    """Every case's attitude error angle and its filter's 3-sigma, one column per filter model.

    At any readable scale the estimated quaternions coincide with the true one (a 100 arcsec error is 5e-4
    in a component), so the figure draws what separates the cases: their errors.

    Parameters
    ----------
    ds : xarray.Dataset
        A main-job results dataset.

    Returns
    -------
    matplotlib.figure.Figure
        The error angle ``|box_minus(q_true, q_est)|`` as a 10 s trailing RMS (arcsec, log scale) in each
        case's style, and the filter's own 3-sigma of that angle as the same colour's dotted line (an error
        under its line is one the filter owns up to). Divergences marked.
    """
    groups = model_groups(ds)
    t = ds["time"].values
    styles = case_styles(str(c) for c in ds["case"].values)
    same = identical_to(ds, "attitude_error")
    fig, axes = new_figure(1, len(groups), time=t, width=4.8 * len(groups) + 1.0, row_height=3.6, sharey="row")
    for col, (model, cases) in enumerate(groups):
        ax = axes[0, col]
        for case in cases:
            style = styles[case]
            angle = np.linalg.norm(ds["attitude_error"].sel(case=case).values, axis=0) / ARCSEC
            rms = moving_rms(t, angle, RMS_WINDOW_S)
            ax.plot(t, rms, label=case_label(case, same), gid=artist_gid(case, "line"), **style.line())
            if case not in same:
                three = 3.0 * np.linalg.norm(ds["attitude_sigma"].sel(case=case).values, axis=0) / ARCSEC
                ax.plot(t, three, color=style.color, zorder=style.zorder - 1.0, gid=artist_gid(case, "band"),
                        label="3σ of the angle, each filter (dotted)", **BAND_EDGE)
            t_div = divergence_time(ds, case)
            if t_div is not None:
                mark_divergence(ax, t_div, last_before(t, rms, t_div), style, case)
        panel_title(ax, col, model_title(model))
        ax.set_yscale("log")
        ax.set_xlabel("time (s)")
    axes[0, 0].set_ylabel(f"attitude error angle, {RMS_WINDOW_S:g} s RMS (arcsec)")
    fig.suptitle(f"Attitude error of B relative to N, and each filter's 3σ\n{subtitle(ds)}", fontsize=11)
    legend_outside(fig)
    return fig


def attitude_error_figure(ds, case: str) -> Figure:
    """One case's attitude error per body axis, within the filter's 3-sigma envelope.

    Parameters
    ----------
    ds : xarray.Dataset
        A main-job results dataset.
    case : str
        The case to draw.

    Returns
    -------
    matplotlib.figure.Figure
        Three rows (about B's x, y, z axes): the error ``box_minus(q_true, q_est)`` (arcsec) in the
        case's style, and ``+-3 sigma`` of the filter's covariance as a grey band.
    """
    t = ds["time"].values
    err = ds["attitude_error"].sel(case=case).values / ARCSEC
    sig = ds["attitude_sigma"].sel(case=case).values / ARCSEC
    style = case_styles(str(c) for c in ds["case"].values)[case]
    others = twins(ds, "attitude_error")[case]
    t_div = divergence_time(ds, case)
    fig, axes = new_figure(3, 1, time=t, width=9.0, row_height=2.2)
    for i, axis in enumerate("xyz"):
        ax = axes[i, 0]
        band_edges(ax, t, -3 * sig[i], 3 * sig[i], style, case, label="±3σ of the filter (dotted)")
        ax.plot(t, err[i], label=" = ".join([case, *others]), gid=artist_gid(case, "line"),
                **{**style.line(), "linewidth": min(style.linewidth, 1.0)})
        ax.set_ylabel(f"$\\delta\\theta_{axis}$ about $B_{axis}$ (arcsec)")
        late = t >= t[0] + 0.1 * (t[-1] - t[0])  # scale on the run after the initial transient
        values = np.abs(np.concatenate([err[i][late], 3 * sig[i][late]]))
        values = values[np.isfinite(values)]
        if values.size and values.max() > 0:
            ax.set_ylim(-1.3 * values.max(), 1.3 * values.max())
        if t_div is not None:
            mark_divergence(ax, t_div, last_before(t, err[i], t_div), style, case, text=i == 0)
    axes[2, 0].set_xlabel("time (s)")
    fig.suptitle(f"Attitude error of {' = '.join([case, *others])} about the body axes, within its filter's ±3σ\n"
                 f"{subtitle(ds)}", fontsize=11)
    legend_outside(fig)
    return fig
