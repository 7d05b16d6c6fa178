"""Writing the main job's results: a self-describing NetCDF file, the JSON summary, the table, figures."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from postcapture.campaign.cases import CASES
from postcapture.core import rotations as rot
from postcapture.dynamics.trajectory import write_atomic

__all__ = ["to_dataset", "write_results", "write_campaign"]


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
    """Write ``results.nc``, ``summary.json``, ``table.txt`` and the figures into ``out_dir``.

    Every file is written to a temporary name and renamed, so an interrupted run never leaves a
    truncated file over an earlier result. Returns the paths written.
    """
    from postcapture.report.figures import main_job_figures
    from postcapture.report.style import DPI
    from postcapture.report.table import results_table

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = result.summary()
    paths = {}
    paths["summary"] = write_atomic(out / "summary.json",
                                    lambda tmp: Path(tmp).write_text(json.dumps(summary, indent=2, default=float)))
    paths["table"] = write_atomic(out / "table.txt", lambda tmp: Path(tmp).write_text(results_table(summary) + "\n"))
    ds = to_dataset(result)
    paths["results"] = write_atomic(out / "results.nc", lambda tmp: ds.to_netcdf(tmp, engine="netcdf4"))
    if not figures:
        return paths
    figs = main_job_figures(ds)
    for stem, fig in figs.items():
        paths[stem] = write_atomic(out / f"{stem}.png", lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=DPI))
    return paths


def write_campaign(result, out_dir, figures: bool = True) -> dict:
    """Write a campaign's ``campaign.nc``, ``summary.json``, ``table.txt`` and figures into ``out_dir``."""
    from postcapture.report.campaign import campaign_figures, campaign_table

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = result.summary()
    paths = {
        "summary": write_atomic(out / "summary.json",
                                lambda tmp: Path(tmp).write_text(json.dumps(summary, indent=2, default=float))),
        "table": write_atomic(out / "table.txt", lambda tmp: Path(tmp).write_text(campaign_table(summary) + "\n")),
    }
    ds = result.to_xarray()
    paths["results"] = write_atomic(out / "campaign.nc", lambda tmp: ds.to_netcdf(tmp, engine="netcdf4"))
    if figures:
        for stem, fig in campaign_figures(ds, summary).items():
            paths[stem] = write_atomic(out / f"{stem}.png", lambda tmp, fig=fig: fig.savefig(tmp, format="png", dpi=110))
    return paths
