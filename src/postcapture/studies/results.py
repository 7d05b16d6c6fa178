"""Writing the main job's results: a self-describing NetCDF file, the JSON summary, the table, figures, a report.

They are written as one set (:class:`postcapture.io.ResultSet`): a reader of the folder sees the previous
complete set or the new complete set, never a mix, and a failure (full disk, Ctrl-C, a kill) leaves
the previous set as it was. The NetCDF files follow CF-1.10 (:mod:`postcapture.io.netcdf`) and every
document carries its provenance (:mod:`postcapture.io.provenance`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from postcapture.core import rotations as rot
from postcapture.io import ResultSet, json_text
from postcapture.io.netcdf import cf_dataset, netcdf_writer
from postcapture.io.provenance import provenance
from postcapture.studies.cases import CASES
from postcapture.studies.target_estimates import INERTIA_COMPONENTS, target_history, true_target

__all__ = ["RUN_FILES", "CAMPAIGN_FILES", "FIGURE_FORMATS", "to_dataset", "write_results", "write_campaign",
           "run_summary"]

FIGURE_FORMATS = ("png", "pdf", "svg")
"""File formats of the figures (``--format``)."""
RUN_FILES = ("results.nc", "summary.json", "table.txt", "report.md", "attitude_estimates.*", "attitude_error_*.*",
             "mass_estimates.*", "mass_error.*", "target_estimates.*", "fig*.png")
"""Names a results folder of the main job holds (``fig*.png``: the figures of earlier versions); other
entries of the folder are kept as they are."""
CAMPAIGN_FILES = ("campaign.nc", "summary.json", "table.txt", "report.md", "campaign_*.*")
"""Names a results folder of a campaign holds."""

_SENSORS = (  # attribute of the sensor suite, variable, label dimension, long name
    ("star", "star_tracker", "quaternion", "star-tracker attitude measurement q_BN, scalar first"),
    ("gyro", "gyro", "axis", "gyro: mean body rate over each sample interval, B components"),
    ("accel", "accelerometer", "axis", "accelerometer: mean specific force at the accelerometer over each sample "
                                       "interval, components in B at the interval's start"),
    ("joints", "joint_encoders", "arm_joint", "arm joint encoders: link-side joint angle, quantised"),
)


def _unit(units) -> str:
    unit = units[0] if units else "1"
    return "1" if unit in ("-", "") else unit


def _sensor_variables(sensors, t) -> tuple[dict, dict]:
    """The recorded measurements as variables (NaN where a sample is missing) and their validity flags."""
    data, coords = {}, {}
    if sensors is None:
        return data, coords
    for attr, name, dim, long_name in _SENSORS:
        m = getattr(sensors, attr, None)
        if m is None:
            continue
        tdim = "time" if m.t.shape == t.shape and np.allclose(m.t, t, rtol=0.0, atol=1e-9) else f"{name}_time"
        if tdim != "time":
            coords[tdim] = (tdim, m.t, {"units": "s", "long_name": f"{name} sample time since the start of the run"})
        data[name] = ((dim, tdim), m.values, {"units": _unit(m.units), "long_name": long_name})
        data[f"{name}_valid"] = ((tdim,), m.valid.astype(np.int8),
                                 {"units": "1", "long_name": f"1 where the {name} sample exists, 0 where it is missing",
                                  "flag_values": np.array([0, 1], dtype=np.int8), "flag_meanings": "missing present"})
    return data, coords


def _case_histories(result, names, n) -> dict:
    out = {k: np.full((len(names), *d, n), np.nan) for k, d in
           (("q_est", (4,)), ("err", (3,)), ("sig", (3,)), ("com", (3,)), ("inertia", (6,)), ("mass", ()),
            ("mass_s", ()), ("nis", ()))}
    out["diverged"] = np.full(len(names), np.nan)
    q_true = result.truth["q_BN"]
    for i, name in enumerate(names):
        r = result.cases[name].result
        h = r.attitude
        out["q_est"][i] = h.q_BN
        ok = np.all(np.isfinite(h.q_BN), axis=0)
        out["err"][i][:, ok] = rot.box_minus(q_true[:, ok], h.q_BN[:, ok])
        out["sig"][i] = np.sqrt(np.einsum("iik->ik", h.P[:3, :3, :]))
        out["mass"][i], out["mass_s"][i], out["nis"][i] = r.mass, r.mass_sigma, h.nis
        out["diverged"][i] = _divergence_time(h)
        params = getattr(r, "params", None)
        if params is not None and result.scenario_model is not None and getattr(result.scenario_model, "target", None):
            out["com"][i], out["inertia"][i] = target_history(result.scenario_model, params)
    return out


def to_dataset(result):
    """Histories of every case, the truth and the sensor records as an :class:`xarray.Dataset` (time last,
    units in attrs); :func:`write_results` writes it in CF form (:func:`postcapture.io.netcdf.cf_dataset`)."""
    import xarray as xr

    t = result.truth.t
    names = list(result.cases)
    h = _case_histories(result, names, t.size)
    com_true, inertia_true = true_target(result.truth_info)
    models = [CASES[name].variant if name in CASES else "other" for name in names]
    sensors, sensor_coords = _sensor_variables(getattr(result, "sensors", None), t)
    ds = xr.Dataset(
        {
            "q_BN_true": (("quaternion", "time"), result.truth["q_BN"],
                          {"units": "1", "long_name": "true attitude of B relative to N, scalar first"}),
            "q_BN_est": (("case", "quaternion", "time"), h["q_est"],
                         {"units": "1", "long_name": "estimated attitude of B relative to N, scalar first"}),
            "attitude_error": (("case", "axis", "time"), h["err"],
                               {"units": "rad", "long_name": "attitude error box_minus(q_true, q_est), B axes"}),
            "attitude_sigma": (("case", "axis", "time"), h["sig"],
                               {"units": "rad", "long_name": "the filter's attitude 1-sigma, B axes"}),
            "mass_est": (("case", "time"), h["mass"], {"units": "kg", "long_name": "target mass estimate"}),
            "mass_sigma": (("case", "time"), h["mass_s"], {"units": "kg", "long_name": "mass estimate 1-sigma"}),
            "com_est": (("case", "axis", "time"), h["com"],
                        {"units": "m", "long_name": "estimated centre of mass of the whole target, grasp frame G "
                                                    "(NaN: the case does not estimate it)"}),
            "inertia_est": (("case", "inertia_component", "time"), h["inertia"],
                            {"units": "kg m2", "long_name": "estimated inertia of the whole target about its centre "
                                                            "of mass, G axes (NaN: not estimated)"}),
            "com_true": (("axis",), com_true, {"units": "m", "long_name": "true centre of mass of the whole "
                                                                           "target, grasp frame G"}),
            "inertia_true": (("inertia_component",), inertia_true,
                             {"units": "kg m2", "long_name": "true inertia of the whole target about its centre of "
                                                             "mass, G axes"}),
            "star_nis": (("case", "time"), h["nis"], {"units": "1", "long_name": "star-tracker NIS"}),
            "diverged_at": (("case",), h["diverged"],
                            {"units": "s", "long_name": "time at which the filter diverged (NaN if it did not)"}),
            **sensors,
        },
        coords={
            "time": ("time", t, {"units": "s", "long_name": "time since the start of the run"}),
            "case": ("case", names, {"long_name": "estimation case"}),
            "filter_model": ("case", models, {"long_name": "variant of the filter's plant model"}),
            "quaternion": ("quaternion", ["w", "x", "y", "z"], {"long_name": "quaternion component, scalar first"}),
            "axis": ("axis", ["x", "y", "z"], {"long_name": "frame axis"}),
            "inertia_component": ("inertia_component", list(INERTIA_COMPONENTS),
                                  {"long_name": "inertia tensor component"}),
            **({"arm_joint": ("arm_joint", [str(k + 1) for k in range(result.sensors.joints.dim)],
                              {"long_name": "arm joint number, from the base"})}
               if getattr(result, "sensors", None) is not None else {}),
            **sensor_coords,
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
            "truth_json": json_text(result.truth_info, indent=None),
            "seed": result.seed,
            "summary_json": json_text(result.summary(), indent=None),
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


def run_summary(result, prov: dict | None = None) -> dict:
    """The main job's summary with its provenance (``"provenance"``): what ``summary.json`` and ``--json`` hold."""
    prov = provenance(getattr(result, "scenario_model", None)) if prov is None else prov
    return {**result.summary(), "provenance": prov}


def _save_figure(fig, fmt: str, dpi: int | None):
    from postcapture.report.style import DPI

    def write(tmp):
        fig.savefig(tmp, format=fmt, dpi=dpi or DPI, metadata={"Date": None} if fmt == "svg" else None)

    return write


def write_results(result, out_dir, figures: bool = True, *, fmt: str = "png", dpi: int | None = None) -> dict:
    """Write ``results.nc``, ``summary.json``, ``table.txt``, the figures and ``report.md`` into ``out_dir``, as one set.

    The files are written into a temporary folder beside ``out_dir``, which then replaces it in one
    step; entries of ``out_dir`` that are not results of the main job are carried over. Returns the
    paths written.

    Parameters
    ----------
    result : MainJobResult
    out_dir : path
    figures : bool
        Draw the figures.
    fmt : {"png", "pdf", "svg"}
        Figure file format.
    dpi : int, optional
        Resolution of PNG figures (default :data:`postcapture.report.style.DPI`).

    Raises
    ------
    OutputPathError
        When ``out_dir`` is not a folder, cannot be written, or a file cannot be written (disk full);
        the previous results are then left as they were.
    """
    from postcapture.report.figures import main_job_figures
    from postcapture.report.report import run_report
    from postcapture.report.table import results_table

    prov = provenance(getattr(result, "scenario_model", None))
    summary = run_summary(result, prov)
    paths = {}
    with ResultSet(out_dir, owned=RUN_FILES, kind="postcapture run") as rs:
        paths["summary"] = rs.write("summary.json", lambda tmp: Path(tmp).write_text(json_text(summary) + "\n"))
        table = results_table(summary)
        paths["table"] = rs.write("table.txt", lambda tmp: Path(tmp).write_text(table + "\n"))
        ds = to_dataset(result)
        paths["results"] = rs.write("results.nc", netcdf_writer(cf_dataset(ds, provenance=prov)))
        names = []
        if figures:
            for stem, fig in main_job_figures(ds).items():
                paths[stem] = rs.write(f"{stem}.{fmt}", _save_figure(fig, fmt, dpi))
                names.append(f"{stem}.{fmt}")
        report = run_report(summary, table, names)
        paths["report"] = rs.write("report.md", lambda tmp: Path(tmp).write_text(report))
    return paths


def write_campaign(result, out_dir, figures: bool = True, *, fmt: str = "png", dpi: int | None = None) -> dict:
    """Write a campaign's ``campaign.nc``, ``summary.json``, ``table.txt``, figures and ``report.md`` into
    ``out_dir``, as one set (see :func:`write_results`)."""
    from postcapture.report.campaign import campaign_figures, campaign_table
    from postcapture.report.report import campaign_report

    prov = provenance(result.scenario)
    summary = {**result.summary(), "provenance": prov}
    with ResultSet(out_dir, owned=CAMPAIGN_FILES, kind="postcapture campaign") as rs:
        table = campaign_table(summary)
        paths = {
            "summary": rs.write("summary.json", lambda tmp: Path(tmp).write_text(json_text(summary) + "\n")),
            "table": rs.write("table.txt", lambda tmp: Path(tmp).write_text(table + "\n")),
        }
        ds = result.to_xarray()
        paths["results"] = rs.write("campaign.nc", netcdf_writer(cf_dataset(ds, provenance=prov)))
        names = []
        if figures:
            for stem, fig in campaign_figures(ds, summary).items():
                paths[stem] = rs.write(f"{stem}.{fmt}", _save_figure(fig, fmt, dpi))
                names.append(f"{stem}.{fmt}")
        report = campaign_report(summary, table, names)
        paths["report"] = rs.write("report.md", lambda tmp: Path(tmp).write_text(report))
    return paths
