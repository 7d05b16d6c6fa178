"""Writing the main job's results: a self-describing NetCDF file, the JSON summary, the table, figures.

They are written as one set (:class:`postcapture.io.ResultSet`): a reader of the folder sees the previous
complete set or the new complete set, never a mix, and a failure (full disk, Ctrl-C, a kill) leaves
the previous set as it was.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from postcapture.studies.cases import CASES
from postcapture.core import rotations as rot
from postcapture.io import ResultSet

__all__ = ["RUN_FILES", "CAMPAIGN_FILES", "to_dataset", "write_results", "write_campaign"]

RUN_FILES = ("results.nc", "summary.json", "table.txt", "attitude_estimates.png", "attitude_error_*.png",
             "mass_estimates.png", "mass_error.png", "fig*.png")
"""Names a results folder of the main job holds (``fig*.png``: the figures of earlier versions); other
entries of the folder are kept as they are."""
CAMPAIGN_FILES = ("campaign.nc", "summary.json", "table.txt", "campaign_*.png")
"""Names a results folder of a campaign holds."""


def to_dataset(result):
    """Histories of every case and the truth as an :class:`xarray.Dataset` (time last, units in attrs)."""
    import xarray as xr

    t = result.truth.t
    names = list(result.cases)
    n = t.size
    q_est = np.full((len(names), 4, n), np.nan)
    err = np.full((len(names), 3, n), np.nan)
    sig = np.full((len(names), 3, n), np.nan)
    mass = np.full((len(names), n), np.nan)
    mass_s = np.full((len(names), n), np.nan)
    nis = np.full((len(names), n), np.nan)
    diverged = np.full(len(names), np.nan)
    for i, name in enumerate(names):
        r = result.cases[name].result
        h = r.attitude
        q_est[i] = h.q_BN
        ok = np.all(np.isfinite(h.q_BN), axis=0)
        err[i][:, ok] = rot.box_minus(result.truth["q_BN"][:, ok], h.q_BN[:, ok])
        sig[i] = np.sqrt(np.einsum("iik->ik", h.P[:3, :3, :]))
        mass[i], mass_s[i], nis[i] = r.mass, r.mass_sigma, h.nis
        diverged[i] = _divergence_time(h)
    models = [CASES[name].variant if name in CASES else "other" for name in names]
    ds = xr.Dataset(
        {
            "q_BN_true": (("quat", "time"), result.truth["q_BN"], {"units": "1", "long_name": "true attitude, scalar first"}),
            "q_BN_est": (("case", "quat", "time"), q_est, {"units": "1", "long_name": "estimated attitude"}),
            "attitude_error": (("case", "axis", "time"), err,
                               {"units": "rad", "long_name": "box_minus(q_true, q_est), body frame"}),
            "attitude_sigma": (("case", "axis", "time"), sig, {"units": "rad", "long_name": "filter 1-sigma"}),
            "mass_est": (("case", "time"), mass, {"units": "kg", "long_name": "target mass estimate"}),
            "mass_sigma": (("case", "time"), mass_s, {"units": "kg", "long_name": "mass estimate 1-sigma"}),
            "star_nis": (("case", "time"), nis, {"units": "1", "long_name": "star-tracker NIS"}),
            "diverged_at": (("case",), diverged,
                            {"units": "s", "long_name": "time at which the filter diverged (NaN if it did not)"}),
        },
        coords={
            "time": ("time", t, {"units": "s", "long_name": "time since the start of the run"}),
            "case": ("case", names, {"long_name": "estimation case"}),
            "filter_model": ("case", models, {"long_name": "variant of the filter's plant model"}),
            "quat": ("quat", ["w", "x", "y", "z"]),
            "axis": ("axis", ["x", "y", "z"]),
        },
        attrs={
            "title": "postcapture main job: attitude and target-mass estimation",
            "scenario": result.scenario,
            "profile": result.profile,
            "plant": result.plant,
            "duration_s": result.duration_s,
            "true_mass_kg": result.true_mass,
            "nominal_mass_kg": result.nominal_mass,
            "initial_mass_kg": result.initial_mass,
            "truth_source": result.truth_info.get("source", "nominal"),
            "truth_json": json.dumps(result.truth_info, default=float),
            "seed": result.seed,
            "summary_json": json.dumps(result.summary(), default=float),
        },
    )
    return ds


def _divergence_time(history) -> float:
    """First instant flagged DIVERGED (or first non-finite estimate) of an attitude history; NaN if none."""
    from postcapture.estimation.history import StepFlag

    flagged = np.nonzero(np.asarray(history.flags) & StepFlag.DIVERGED)[0]
    if flagged.size:
        return float(history.t[flagged[0]])
    if history.success:
        return float("nan")
    bad = np.nonzero(~np.all(np.isfinite(history.q_BN), axis=0))[0]
    return float(history.t[bad[0]]) if bad.size else float("nan")


def write_results(result, out_dir, figures: bool = True) -> dict:
    """Write ``results.nc``, ``summary.json``, ``table.txt`` and the figures into ``out_dir``, as one set.

    The files are written into a temporary folder beside ``out_dir``, which then replaces it in one
    step; entries of ``out_dir`` that are not results of the main job are carried over. Returns the
    paths written.

    Raises
    ------
    OutputPathError
        When ``out_dir`` is not a folder, cannot be written, or a file cannot be written (disk full);
        the previous results are then left as they were.
    """
    from postcapture.report.figures import main_job_figures
    from postcapture.report.style import DPI
    from postcapture.report.table import results_table

    summary = result.summary()
    paths = {}
    with ResultSet(out_dir, owned=RUN_FILES, kind="postcapture run") as rs:
        paths["summary"] = rs.write("summary.json",
                                    lambda tmp: Path(tmp).write_text(json.dumps(summary, indent=2, default=float)))
        paths["table"] = rs.write("table.txt", lambda tmp: Path(tmp).write_text(results_table(summary) + "\n"))
        ds = to_dataset(result)
        paths["results"] = rs.write("results.nc", lambda tmp: ds.to_netcdf(tmp, engine="netcdf4"))
        if figures:
            for stem, fig in main_job_figures(ds).items():
                paths[stem] = rs.write(f"{stem}.png", lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=DPI))
    return paths


def write_campaign(result, out_dir, figures: bool = True) -> dict:
    """Write a campaign's ``campaign.nc``, ``summary.json``, ``table.txt`` and figures into ``out_dir``, as one
    set (see :func:`write_results`)."""
    from postcapture.report.campaign import campaign_figures, campaign_table

    summary = result.summary()
    with ResultSet(out_dir, owned=CAMPAIGN_FILES, kind="postcapture campaign") as rs:
        paths = {
            "summary": rs.write("summary.json",
                                lambda tmp: Path(tmp).write_text(json.dumps(summary, indent=2, default=float))),
            "table": rs.write("table.txt", lambda tmp: Path(tmp).write_text(campaign_table(summary) + "\n")),
        }
        ds = result.to_xarray()
        paths["results"] = rs.write("campaign.nc", lambda tmp: ds.to_netcdf(tmp, engine="netcdf4"))
        if figures:
            for stem, fig in campaign_figures(ds, summary).items():
                paths[stem] = rs.write(f"{stem}.png", lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=110))
    return paths
