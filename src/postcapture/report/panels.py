"""Figures of a panel calibration: tip-response spectra (the reference's figure 2) and mode shapes.

Drawing only: every number comes in the plain-array dictionary of
`postcapture.panels.calibration.CalibrationResult.plot_data`. Figures are built with
``matplotlib.figure.Figure`` directly (no pyplot, no global state, any backend; saving renders with
Agg).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.figure import Figure

__all__ = ["spectra_figure", "mode_shapes_figure", "calibration_figures"]

_FEM_STYLE = {"color": "black", "lw": 1.4}
_COLOURS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


def spectra_figure(spectra: Mapping, *, title: str = "") -> Figure:
    """Single-sided amplitude spectra of the tip displacement, reference vs each lumped run.

    Parameters
    ----------
    spectra : mapping
        ``freqs`` (n_f,) (Hz); ``fem`` (n_f,) and ``lumped`` {label: (n_f,)} amplitudes (m); optionally
        the same zero-padded, ``freqs_fine``, ``fem_fine`` and ``lumped_fine``, drawn around the peak;
        ``fem_peak_hz`` (Hz) and ``peaks_hz`` {label: Hz}, the interpolated first peaks;
        ``band`` (f_start, f_stop) of the sweep (Hz).
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        One row per run: the whole sweep band (log amplitude) and a zoom on the first peak (linear:
        the zero-padded spectrum as lines, the record's bins as dots), the first peaks marked by
        vertical lines.
    """
    freqs = np.asarray(spectra["freqs"])
    fem = np.asarray(spectra["fem"])
    labels = list(spectra["lumped"])
    f_peak = float(spectra["fem_peak_hz"])
    f_hi = float(spectra["band"][1])
    fig = Figure(figsize=(10.0, 2.6 * len(labels) + 0.6), layout="constrained")
    axes = fig.subplots(len(labels), 2, squeeze=False)
    full = (freqs > 0) & (freqs <= 1.1 * f_hi)
    zoom = (freqs > 0) & (freqs <= 2.5 * f_peak)
    fine = np.asarray(spectra.get("freqs_fine", freqs))
    zoom_fine = (fine > 0) & (fine <= 2.5 * f_peak)
    for row, label in enumerate(labels):
        amp = np.asarray(spectra["lumped"][label])
        peak = float(spectra["peaks_hz"][label])
        colour = _COLOURS[row % len(_COLOURS)]
        ax = axes[row, 0]
        ax.plot(freqs[full], fem[full], label="FEM", **_FEM_STYLE)
        ax.plot(freqs[full], amp[full], color=colour, lw=1.2, label=f"lumped {label}")
        ax.set_yscale("log")
        ax = axes[row, 1]
        fem_fine = np.asarray(spectra.get("fem_fine", fem))
        amp_fine = np.asarray(spectra.get("lumped_fine", spectra["lumped"])[label])
        ax.plot(fine[zoom_fine], fem_fine[zoom_fine], label=f"FEM (peak {f_peak:.5f} Hz)", **_FEM_STYLE)
        ax.plot(fine[zoom_fine], amp_fine[zoom_fine], color=colour, lw=1.2,
                label=f"lumped {label} (peak {peak:.5f} Hz)")
        ax.plot(freqs[zoom], fem[zoom], "o", color="black", ms=3)
        ax.plot(freqs[zoom], amp[zoom], "o", color=colour, ms=3)
        for ax in axes[row]:
            ax.axvline(f_peak, color="black", ls="--", lw=0.8)
            ax.axvline(peak, color=colour, ls=":", lw=1.0)
            ax.set_ylabel("|W(f)| (m)")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(loc="upper right", fontsize=8)
    for col in range(2):
        axes[-1, col].set_xlabel("frequency (Hz)")
    axes[0, 0].set_title("single-sided amplitude spectrum of the tip displacement")
    axes[0, 1].set_title("first resonance (dots: the record's bins)")
    if title:
        fig.suptitle(title)
    return fig


def mode_shapes_figure(shapes: Mapping, *, title: str = "") -> Figure:
    """Bending mode shapes along the centreline: the reference's curve and each chain's joints.

    Parameters
    ----------
    shapes : mapping
        ``fem_stations`` (n_fine,) (m) and ``fem_w`` (n_fine, n); ``joint_stations`` (N + 1,) (m) and
        ``lumped_w`` {label: (N + 1, n)}, all with unit tip deflection; ``fem_hz`` (n,),
        ``lumped_hz`` {label: (n,)} (Hz) and ``mac`` {label: (n,)} (-).
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        One panel per bending mode.
    """
    s_fem = np.asarray(shapes["fem_stations"])
    w_fem = np.asarray(shapes["fem_w"])
    s_joint = np.asarray(shapes["joint_stations"])
    n = w_fem.shape[1]
    fig = Figure(figsize=(4.0 * n, 3.4), layout="constrained")
    axes = fig.subplots(1, n, squeeze=False)[0]
    for j, ax in enumerate(axes):
        ax.plot(s_fem, w_fem[:, j], label=f"FEM {shapes['fem_hz'][j]:.4f} Hz", **_FEM_STYLE)
        for row, (label, w) in enumerate(shapes["lumped_w"].items()):
            f_j, mac_j = shapes["lumped_hz"][label][j], shapes["mac"][label][j]
            ax.plot(s_joint, np.asarray(w)[:, j], "o-", ms=4, lw=1.0, color=_COLOURS[row % len(_COLOURS)],
                    label=f"{label}: {f_j:.4f} Hz, MAC {mac_j:.4f}")
        ax.axhline(0.0, color="grey", lw=0.5)
        ax.set_title(f"bending mode {j + 1}")
        ax.set_xlabel("distance from the root (m)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    axes[0].set_ylabel("w / w(tip) (-)")
    if title:
        fig.suptitle(title)
    return fig


def calibration_figures(data: Mapping) -> dict[str, Figure]:
    """Both figures of a calibration, keyed by file stem.

    Parameters
    ----------
    data : mapping
        `postcapture.panels.calibration.CalibrationResult.plot_data`.

    Returns
    -------
    dict of str to matplotlib.figure.Figure
        ``"sweep_spectra"`` (`spectra_figure`) and ``"mode_shapes"`` (`mode_shapes_figure`).
    """
    name = f"{data['name']}, N = {data['segments']}"
    return {"sweep_spectra": spectra_figure(data["spectra"], title=f"Sine-sweep validation: {name}"),
            "mode_shapes": mode_shapes_figure(data["shapes"], title=f"Bending modes: {name}")}
