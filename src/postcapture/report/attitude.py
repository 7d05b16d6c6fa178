"""Attitude figures of the main job: estimates against the truth, and errors against the filters' 3 sigma.

- :func:`attitude_estimates_figure` (the reference's figures 4a and 6a): the fourth quaternion
  component of every case over the truth, made sign-continuous (a quaternion and its negative are the
  same attitude; the stored ``w >= 0`` convention jumps from +q to -q when w crosses zero), and
  below it the attitude error angle, where the cases separate.
- :func:`attitude_error_figure` (the reference's figure 4b): one case's error per body axis within
  the filter's own 3-sigma envelope.

Both read a results dataset (``postcapture.studies.results.to_dataset``).
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
    BAND_ALPHA,
    TRUTH_STYLE,
    artist_gid,
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
    """Fourth quaternion component (sign-continuous) and error angle, one column per filter model.

    Parameters
    ----------
    ds : xarray.Dataset
        A main-job results dataset.

    Returns
    -------
    matplotlib.figure.Figure
        Top row: ``q_z`` of every case over the truth; bottom row: the attitude error angle
        ``|box_minus(q_true, q_est)|`` as a 10 s trailing RMS (arcsec, log scale). Divergences marked.
    """
    groups = model_groups(ds)
    t = ds["time"].values
    q_true = sign_continuous(ds["q_BN_true"].values)
    styles = case_styles(str(c) for c in ds["case"].values)
    same = identical_to(ds, "q_BN_est")
    fig, axes = new_figure(2, len(groups), time=t, width=4.8 * len(groups) + 1.0, row_height=2.9, sharey="row")
    for col, (model, cases) in enumerate(groups):
        ax_q, ax_e = axes[0, col], axes[1, col]
        ax_q.plot(t, q_true[3], **TRUTH_STYLE)
        for case in cases:
            style = styles[case]
            q = align_to(ds["q_BN_est"].sel(case=case).values, q_true)
            ax_q.plot(t, q[3], label=case_label(case, same), gid=artist_gid(case, "line"), **style.line())
            angle = np.linalg.norm(ds["attitude_error"].sel(case=case).values, axis=0) / ARCSEC
            rms = moving_rms(t, angle, RMS_WINDOW_S)
            ax_e.plot(t, rms, gid=artist_gid(case, "line"), **style.line())
            t_div = divergence_time(ds, case)
            if t_div is not None:
                mark_divergence(ax_e, t_div, last_before(t, rms, t_div), style, case)
        panel_title(ax_q, col, model_title(model))
        ax_e.set_yscale("log")
        ax_e.set_xlabel("time (s)")
    axes[0, 0].set_ylabel("$q_z$ of $q_{BN}$ (-), sign-continuous")
    axes[1, 0].set_ylabel(f"error angle, {RMS_WINDOW_S:g} s RMS (arcsec)")
    fig.suptitle(f"Attitude estimates and error, body frame B relative to N\n{subtitle(ds)}", fontsize=11)
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
    same = identical_to(ds, "attitude_error")
    others = twins(ds, "attitude_error")[case]
    t_div = divergence_time(ds, case)
    fig, axes = new_figure(3, 1, time=t, width=9.0, row_height=2.2)
    for i, axis in enumerate("xyz"):
        ax = axes[i, 0]
        ok = np.isfinite(sig[i])
        ax.fill_between(t[ok], -3 * sig[i][ok], 3 * sig[i][ok], color="0.5", alpha=BAND_ALPHA * 2, linewidth=0,
                        label="±3σ of the filter", gid=artist_gid(case, "band"))
        ax.plot(t, err[i], label=case_label(case, same), gid=artist_gid(case, "line"),
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
    note = f"; identical to {', '.join(others)}" if others else ""
    fig.suptitle(f"Attitude error of {case} (true relative to estimated, body axes){note}\n{subtitle(ds)}",
                 fontsize=11)
    legend_outside(fig)
    return fig
