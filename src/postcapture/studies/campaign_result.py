"""A campaign's results: the runs, their dataset (run x case x time) and the summary that judges them.

Consistency is Bar-Shalom's: over ``N`` runs the NEES averaged across runs at each instant should lie in
the two-sided 95 % chi-square band ``chi2.ppf([0.025, 0.975], N n) / N`` (``n`` the dimension); the
summary gives its time average against that band, for the mass (n = 1) and the attitude (n = 3).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from postcapture.core.consistency import chi2_bounds, run_averaged_nees
from postcapture.io import json_text

__all__ = ["CampaignResult", "summarize", "truth_unit", "truth_variable"]


@dataclass
class CampaignResult:
    """A campaign's runs and what they say: the same surface as :class:`postcapture.RunResult`.

    Attributes
    ----------
    settings : dict
        The campaign's settings (its manifest).
    t : ndarray (n_t,)
        Filter instants (s).
    runs : list of dict
        Per run (sorted by run index): ``truth`` vector, ``true_mass``, per-case histories.
    truth_names : tuple of str
    wall_s : float
    resumed : int
        Runs loaded from a previous, interrupted campaign.
    crlb : object
        The mass Cramer-Rao bound on the nominal model (None if not computed).
    """

    settings: dict
    t: np.ndarray
    runs: list
    truth_names: tuple
    wall_s: float = 0.0
    resumed: int = 0
    crlb: object = None

    def __repr__(self) -> str:
        s = self.settings
        kind = "dispersed" if s.get("dispersed") else "one truth"
        return (f"CampaignResult(scenario {s.get('scenario')!r}, {s.get('profile')} profile, {len(self.runs)} runs "
                f"({kind}), {self.t[-1] - self.t[0] if self.t.size else 0:g} s; cases {', '.join(self.cases)})")

    @property
    def cases(self) -> tuple[str, ...]:
        """Case names."""
        return tuple(self.settings["cases"])

    @property
    def scenario(self):
        """The nominal scenario the campaign ran (from its manifest)."""
        from postcapture.config.schema import Scenario

        return Scenario.model_validate_json(self.settings["scenario_json"])

    def summary(self) -> dict:
        """``{"cases": {name: {...}}, "runs": N, "wall_s": ...}`` (see :func:`summarize`)."""
        return summarize(self)

    @property
    def table(self) -> str:
        """The table ``postcapture campaign`` prints (80 columns)."""
        from postcapture.report.campaign import campaign_table

        return campaign_table(self.summary())

    def to_pandas(self):
        """One row per case, one column per scalar figure of merit of :meth:`summary`.

        Returns
        -------
        pandas.DataFrame
            Indexed by case; columns such as ``mass_error_rms_kg``, ``inside_3sigma_fraction``, ``nees_mean``,
            ``diverged_runs`` (and whatever the summary gains later).
        """
        import pandas as pd

        rows = {name: {k: v for k, v in c.items() if not isinstance(v, (list, dict))}
                for name, c in self.summary()["cases"].items()}
        frame = pd.DataFrame.from_dict(rows, orient="index")
        frame.index.name = "case"
        return frame

    def figures(self) -> dict:
        """The campaign's figures keyed by file stem (:func:`postcapture.report.campaign.campaign_figures`)."""
        from postcapture.report.campaign import campaign_figures

        return campaign_figures(self.to_xarray(), self.summary())

    def write(self, out_dir, *, figures: bool = True, fmt: str = "png", dpi: int | None = None) -> dict:
        """Write ``campaign.nc``, ``summary.json``, ``table.txt``, the figures and ``report.md``; the paths."""
        from postcapture.studies.results import write_campaign

        return write_campaign(self, out_dir, figures=figures, fmt=fmt, dpi=dpi)

    def _stack(self, key, shape=()):
        cases = self.cases
        out = np.full((len(self.runs), len(cases), *shape, self.t.size), np.nan)
        for i, run in enumerate(self.runs):
            for j, c in enumerate(cases):
                out[i, j] = run["cases"][c][key]
        return out

    def _final(self, key):
        return np.array([[run["cases"][c][key] for c in self.cases] for run in self.runs])

    def to_xarray(self):
        """Every run as an :class:`xarray.Dataset` (run x case x time): errors, sigmas, NEES, the final target
        errors, and each true parameter of each run as a variable of its own unit (``truth_<name>``)."""
        import xarray as xr

        rc, rca = ("run", "case"), ("run", "case", "axis")
        data = {
            "mass_error": (rc + ("time",), self._stack("mass_error"),
                           {"units": "kg", "long_name": "mass estimate minus the run's true target mass"}),
            "mass_sigma": (rc + ("time",), self._stack("mass_sigma"),
                           {"units": "kg", "long_name": "the filter's 1-sigma of the mass"}),
            "attitude_error": (rca + ("time",), self._stack("attitude_error", (3,)),
                               {"units": "rad", "long_name": "attitude error box_minus(q_true, q_est), B axes"}),
            "attitude_sigma": (rca + ("time",), self._stack("attitude_sigma", (3,)),
                               {"units": "rad", "long_name": "the filter's attitude 1-sigma, B axes"}),
            "attitude_nees": (rc + ("time",), self._stack("attitude_nees"),
                              {"units": "1", "long_name": "attitude NEES (3 degrees of freedom)"}),
            "com_error": (rca, self._final("com_error"),
                          {"units": "m", "long_name": "final error of the whole target's centre of mass, grasp frame"}),
            "inertia_error": (rc + ("inertia_component",), self._final("inertia_error"),
                              {"units": "kg m2", "long_name": "final error of the target's inertia about its CoM"}),
            "com_sigma": (rca, self._final("com_sigma"),
                          {"units": "m", "long_name": "the filter's final 1-sigma of the target's centre of mass"}),
            "inertia_sigma": (rc + ("inertia_component",), self._final("inertia_sigma"),
                              {"units": "kg m2", "long_name": "the filter's final 1-sigma of the target's inertia"}),
            "diverged_at": (rc, self._final("diverged_at").astype(float),
                            {"units": "s", "long_name": "time of divergence (NaN: none)"}),
        }
        truth = np.array([run["truth"] for run in self.runs]).reshape(len(self.runs), len(self.truth_names))
        for k, name in enumerate(self.truth_names):
            data[truth_variable(name)] = (("run",), truth[:, k], {"units": truth_unit(name),
                                                                  "long_name": f"the run's true {name}"})
        s = self.summary()
        return xr.Dataset(data, coords={
            "run": ("run", np.array([run["run"] for run in self.runs], dtype=np.int64), {"long_name": "run number"}),
            "case": ("case", list(self.cases), {"long_name": "estimation case"}),
            "time": ("time", self.t, {"units": "s", "long_name": "time since the start of the run"}),
            "axis": ("axis", ["x", "y", "z"], {"long_name": "frame axis"}),
            "inertia_component": ("inertia_component", ["xx", "yy", "zz", "xy", "xz", "yz"],
                                  {"long_name": "inertia tensor component"}),
        }, attrs={"title": "postcapture Monte Carlo campaign", "scenario": s.get("scenario") or "",
                  "profile": s.get("profile") or "", "seed": s.get("seed") if s.get("seed") is not None else -1,
                  "runs": s["runs"], "dispersed": int(bool(s.get("dispersed"))),
                  "settings_json": json_text({k: v for k, v in self.settings.items() if k != "scenario_json"},
                                             indent=None),
                  "summary_json": json_text(s, indent=None)})


_TRUTH_UNITS = (("target_mass", "kg"), ("target_com_", "m"), ("target_I_", "kg m2"), ("gyro_bias_", "rad/s"),
                ("accel_bias_", "m/s2"))


def truth_unit(name: str) -> str:
    """The unit of a true parameter by its name (:func:`postcapture.dynamics.truth.truth_vector_names`): kg, m,
    kg m2, rad/s, m/s2, or 1 for the factors (``*_scale``)."""
    return next((unit for prefix, unit in _TRUTH_UNITS if name.startswith(prefix)), "1")


def truth_variable(name: str) -> str:
    """``truth_<name>`` with the characters CF does not allow in a variable name made ``_``."""
    return "truth_" + "".join(c if c.isascii() and (c.isalnum() or c == "_") else "_" for c in name)


def _final(values: np.ndarray) -> float:
    """The last finite value of a history (NaN if none)."""
    ok = np.nonzero(np.isfinite(values))[0]
    return float(values[ok[-1]]) if ok.size else float("nan")


def _bounds(result: CampaignResult) -> dict:
    if result.crlb is None:
        return {"crlb_kg": None, "crlb_known_model_kg": None, "crlb_parameters_only_kg": None}
    return {"crlb_kg": result.crlb["nuisance"].all_sensors, "crlb_known_model_kg": result.crlb["known_model"].all_sensors,
            "crlb_parameters_only_kg": result.crlb["parameters"].all_sensors}


def _mean(x, mask):
    return float(np.mean(x[mask])) if mask.any() else None


def _mass_stats(rows) -> dict:
    """Final mass errors over every run: a diverged run counts with its last estimate (and as outside its 3
    sigma, whatever that estimate), the survivors' figures beside."""
    err = np.array([_final(c["mass_error"]) for c in rows])
    sig = np.array([_final(c["mass_sigma"]) for c in rows])
    failed = np.array([np.isfinite(c["diverged_at"]) for c in rows], dtype=bool)
    has = np.isfinite(err) & np.isfinite(sig)
    ok = has & ~failed
    return {
        "mass_error_mean_kg": _mean(err, has),
        "mass_error_std_kg": float(np.std(err[has], ddof=1)) if has.sum() > 1 else None,
        "mass_error_rms_kg": float(np.sqrt(np.mean(err[has] ** 2))) if has.any() else None,
        "mass_error_rms_survivors_kg": float(np.sqrt(np.mean(err[ok] ** 2))) if ok.any() else None,
        "runs_without_estimate": int((~has).sum()),
        "mass_sigma_mean_kg": _mean(sig, has),
        # the share of all runs whose final mass error lies inside their own filter's 3 sigma
        "inside_3sigma_fraction": float(np.mean(ok & (np.abs(err) <= 3.0 * sig))) if rows else None,
        "final_errors_kg": [float(x) for x in err],
        "diverged_runs": int(failed.sum()),
    }


def _nees_stats(rows, t_grid, n) -> dict:
    """Run-averaged NEES (mass 1, attitude 3) over time against the 95 % band: over every run, every instant
    (a diverged filter's too), and over the survivors (the runs whose filters never diverged)."""
    lo1, hi1 = chi2_bounds(1, n) if n else (float("nan"),) * 2
    lo3, hi3 = chi2_bounds(3, n) if n else (float("nan"),) * 2
    failed = np.array([np.isfinite(c["diverged_at"]) for c in rows], dtype=bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        mass_nees = np.array([(c["mass_error"] / c["mass_sigma"]) ** 2 for c in rows])
    att_nees = np.array([c["attitude_nees"] for c in rows])
    keep_all = np.full(len(rows), np.nan)
    survivors = np.where(failed, -np.inf, np.nan)  # a diverged run is left out from the start

    def averaged(z, stop, band):
        avg = run_averaged_nees(z, t_grid, stop)[1:] if n else np.array([np.nan])
        mean = float(np.nanmean(avg)) if np.isfinite(avg).any() else None
        return mean, avg

    m_all, avg_m = averaged(mass_nees, keep_all, (lo1, hi1))
    m_surv, _ = averaged(mass_nees, survivors, (lo1, hi1))
    a_all, _ = averaged(att_nees, keep_all, (lo3, hi3))
    a_surv, _ = averaged(att_nees, survivors, (lo3, hi3))
    return {
        "nees_mean": m_all,
        "nees_mean_survivors": m_surv,
        "nees_band": [float(lo1), float(hi1)],
        # the share of the filter instants at which the run-averaged mass NEES lies inside its band
        "nees_inside_band_fraction": float(np.mean((avg_m >= lo1) & (avg_m <= hi1))),
        "attitude_nees_mean": a_all,
        "attitude_nees_mean_survivors": a_surv,
        "attitude_nees_band": [float(lo3), float(hi3)],
    }


def _target_stats(rows) -> dict:
    """Final CoM and inertia errors over every run that has them (a diverged run with its last estimate), and the
    share of (run, component) pairs inside the filter's own 3 sigma (a diverged run's count as outside)."""
    failed = np.array([np.isfinite(c["diverged_at"]) for c in rows], dtype=bool)
    com, inertia = np.array([c["com_error"] for c in rows]), np.array([c["inertia_error"] for c in rows])
    com_s, inertia_s = np.array([c["com_sigma"] for c in rows]), np.array([c["inertia_sigma"] for c in rows])
    has = np.isfinite(com).all(axis=1) if rows else np.zeros(0, bool)
    has_s = has & np.isfinite(com_s).all(axis=1) & np.isfinite(inertia_s).all(axis=1) if rows else has

    def inside(err, sig):
        ok = (np.abs(err) <= 3.0 * sig) & ~failed[:, None]
        return float(np.mean(ok[has_s])) if has_s.any() else None

    def per_component(err, sig):
        ok = (np.abs(err) <= 3.0 * sig) & ~failed[:, None]
        return [float(x) for x in np.mean(ok[has_s], axis=0)] if has_s.any() else None

    return {
        "com_error_rms_m": float(np.sqrt(np.mean(np.sum(com[has] ** 2, axis=1)))) if has.any() else None,
        "inertia_error_rms_kgm2": (float(np.sqrt(np.mean(np.sum(inertia[has, :3] ** 2, axis=1) / 3)))
                                   if has.any() else None),
        "com_inside_3sigma_fraction": inside(com, com_s),
        "inertia_inside_3sigma_fraction": inside(inertia, inertia_s),
        # per component (CoM x, y, z; inertia xx, yy, zz, xy, xz, yz): the share of runs inside their 3 sigma
        "com_inside_3sigma_by_component": per_component(com, com_s),
        "inertia_inside_3sigma_by_component": per_component(inertia, inertia_s),
    }


def summarize(result: CampaignResult) -> dict:
    """Per case: final mass error mean, std and RMS over every run (diverged ones included, with their last
    estimate; the survivors' RMS beside), the share of all runs inside their own 3 sigma, the time-averaged
    NEES (mass and attitude) over all runs and over the survivors against the chi-square 95 % band for that
    many runs, diverged runs, the final CoM and inertia errors and the Cramer-Rao bound."""
    n = len(result.runs)
    out = {"cases": {}, "runs": n, "dispersed": result.settings.get("dispersed", False),
           "profile": result.settings.get("profile"), "scenario": result.settings.get("scenario"),
           "seed": result.settings.get("seed"), "truth": result.settings.get("truth"), "wall_s": result.wall_s,
           "resumed_runs": result.resumed}
    t_grid = np.asarray(result.t, dtype=float)
    for case in result.cases:
        rows = [run["cases"][case] for run in result.runs]
        out["cases"][case] = {**_target_stats(rows), **_mass_stats(rows), **_nees_stats(rows, t_grid, n),
                              **_bounds(result)}
    return out
