"""A campaign's results: the runs, their dataset (run x case x time) and the summary that judges them.

Consistency is Bar-Shalom's: over ``N`` runs the NEES averaged across runs at each instant should lie in
the two-sided 95 % chi-square band ``chi2.ppf([0.025, 0.975], N n) / N`` (``n`` the dimension); the
summary gives its time average against that band, for the mass (n = 1) and the attitude (n = 3).
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from postcapture.core.consistency import chi2_bounds, run_averaged_nees

__all__ = ["CampaignResult", "summarize"]


@dataclass
class CampaignResult:
    """A campaign's runs and what they say.

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

    @property
    def cases(self) -> tuple[str, ...]:
        """Case names."""
        return tuple(self.settings["cases"])

    def summary(self) -> dict:
        """``{"cases": {name: {...}}, "runs": N, "wall_s": ...}`` (see :func:`summarize`)."""
        return summarize(self)

    def to_xarray(self):
        """Every run as an :class:`xarray.Dataset` (run x case x time), the truth parameters per run."""
        import xarray as xr

        cases = list(self.cases)
        n_r, n_c, n_t = len(self.runs), len(cases), self.t.size

        def stack(key, shape=()):
            out = np.full((n_r, n_c, *shape, n_t), np.nan)
            for i, run in enumerate(self.runs):
                for j, c in enumerate(cases):
                    out[i, j] = run["cases"][c][key]
            return out

        truth = np.array([run["truth"] for run in self.runs])
        diverged = np.array([[run["cases"][c]["diverged_at"] for c in cases] for run in self.runs])
        s = self.summary()
        return xr.Dataset(
            {
                "mass_error": (("run", "case", "time"), stack("mass_error"),
                               {"units": "kg", "long_name": "mass estimate minus the run's true target mass"}),
                "mass_sigma": (("run", "case", "time"), stack("mass_sigma"),
                               {"units": "kg", "long_name": "the filter's 1-sigma of the mass"}),
                "attitude_error": (("run", "case", "axis", "time"), stack("attitude_error", (3,)),
                                   {"units": "rad", "long_name": "box_minus(q_true, q_est), body frame"}),
                "attitude_sigma": (("run", "case", "axis", "time"), stack("attitude_sigma", (3,)),
                                   {"units": "rad", "long_name": "the filter's attitude 1-sigma"}),
                "attitude_nees": (("run", "case", "time"), stack("attitude_nees"),
                                  {"units": "1", "long_name": "attitude NEES (3 degrees of freedom)"}),
                "com_error": (("run", "case", "axis"), np.array([[run["cases"][c]["com_error"] for c in cases]
                                                                 for run in self.runs]),
                              {"units": "m", "long_name": "final error of the target's centre of mass, grasp frame"}),
                "inertia_error": (("run", "case", "inertia_component"),
                                  np.array([[run["cases"][c]["inertia_error"] for c in cases] for run in self.runs]),
                                  {"units": "kg m2", "long_name": "final error of the target's inertia about its CoM"}),
                "com_sigma": (("run", "case", "axis"), np.array([[run["cases"][c]["com_sigma"] for c in cases]
                                                                 for run in self.runs]),
                              {"units": "m", "long_name": "the filter's final 1-sigma of the target's centre of mass"}),
                "inertia_sigma": (("run", "case", "inertia_component"),
                                  np.array([[run["cases"][c]["inertia_sigma"] for c in cases] for run in self.runs]),
                                  {"units": "kg m2", "long_name": "the filter's final 1-sigma of the target's inertia"}),
                "diverged_at": (("run", "case"), diverged,
                                {"units": "s", "long_name": "time of divergence (NaN: none)"}),
                "truth": (("run", "truth_parameter"), truth,
                          {"long_name": "the run's true parameters (units: kg, m, kg m2, factors, rad/s, m/s2 by name)"}),
            },
            coords={
                "run": ("run", np.array([run["run"] for run in self.runs])),
                "case": ("case", cases),
                "time": ("time", self.t, {"units": "s"}),
                "axis": ("axis", ["x", "y", "z"]),
                "inertia_component": ("inertia_component", ["xx", "yy", "zz", "xy", "xz", "yz"]),
                "truth_parameter": ("truth_parameter", list(self.truth_names)),
            },
            attrs={
                "title": "postcapture Monte Carlo campaign",
                "settings_json": json.dumps(self.settings),
                "summary_json": json.dumps(s, default=float),
            },
        )


def _final(values: np.ndarray) -> float:
    """The last finite value of a history (NaN if none)."""
    ok = np.nonzero(np.isfinite(values))[0]
    return float(values[ok[-1]]) if ok.size else float("nan")


def summarize(result: CampaignResult) -> dict:
    """Per case: final mass error mean, std and RMS over the runs, the share of runs inside their own 3 sigma,
    the time-averaged NEES (mass and attitude) against the chi-square 95 % band for that many runs,
    diverged runs and the Cramer-Rao bound."""
    n = len(result.runs)
    lo1, hi1 = chi2_bounds(1, n) if n else (float("nan"),) * 2
    lo3, hi3 = chi2_bounds(3, n) if n else (float("nan"),) * 2
    crlb = result.crlb["nuisance"].all_sensors if result.crlb is not None else None
    crlb_known = result.crlb["known_model"].all_sensors if result.crlb is not None else None
    crlb_params = result.crlb["parameters"].all_sensors if result.crlb is not None else None
    out = {"cases": {}, "runs": n, "dispersed": result.settings.get("dispersed", False),
           "profile": result.settings.get("profile"), "scenario": result.settings.get("scenario"),
           "seed": result.settings.get("seed"), "wall_s": result.wall_s, "resumed_runs": result.resumed}
    for case in result.cases:
        rows = [run["cases"][case] for run in result.runs]
        err = np.array([_final(c["mass_error"]) for c in rows])
        sig = np.array([_final(c["mass_sigma"]) for c in rows])
        failed = np.array([np.isfinite(c["diverged_at"]) for c in rows], dtype=bool)
        diverged = int(failed.sum())
        ok = np.isfinite(err) & np.isfinite(sig) & ~failed  # a diverged run counts as a miss, whatever its last value
        stop = np.array([c["diverged_at"] for c in rows])  # a diverged filter's NEES is left out from then on
        with np.errstate(invalid="ignore", divide="ignore"):
            mass_nees = np.array([(c["mass_error"] / c["mass_sigma"]) ** 2 for c in rows])
        att_nees = np.array([c["attitude_nees"] for c in rows])
        t_grid = np.asarray(result.t, dtype=float)
        avg_m = run_averaged_nees(mass_nees, t_grid, stop)[1:] if n else np.array([np.nan])
        avg_a = run_averaged_nees(att_nees, t_grid, stop)[1:] if n else np.array([np.nan])
        com = np.array([c["com_error"] for c in rows])
        inertia = np.array([c["inertia_error"] for c in rows])
        has_target = np.isfinite(com).all(axis=1) & ~failed
        com_s = np.array([c["com_sigma"] for c in rows])
        inertia_s = np.array([c["inertia_sigma"] for c in rows])
        has_sigma = has_target & np.isfinite(com_s).all(axis=1) & np.isfinite(inertia_s).all(axis=1)
        out["cases"][case] = {
            "com_error_rms_m": float(np.sqrt(np.mean(np.sum(com[has_target] ** 2, axis=1)))) if has_target.any() else None,
            "inertia_error_rms_kgm2": (float(np.sqrt(np.mean(np.sum(inertia[has_target, :3] ** 2, axis=1) / 3)))
                                       if has_target.any() else None),
            # the share of (run, component) pairs whose final error lies inside the filter's own 3 sigma
            "com_inside_3sigma_fraction": (float(np.mean(np.abs(com[has_sigma]) <= 3.0 * com_s[has_sigma]))
                                           if has_sigma.any() else None),
            "inertia_inside_3sigma_fraction": (float(np.mean(np.abs(inertia[has_sigma]) <= 3.0 * inertia_s[has_sigma]))
                                               if has_sigma.any() else None),
            "mass_error_mean_kg": float(np.mean(err[ok])) if ok.any() else None,
            "mass_error_std_kg": float(np.std(err[ok], ddof=1)) if ok.sum() > 1 else None,
            "mass_error_rms_kg": float(np.sqrt(np.mean(err[ok] ** 2))) if ok.any() else None,
            "mass_sigma_mean_kg": float(np.mean(sig[ok])) if ok.any() else None,
            "inside_3sigma_fraction": float(np.mean(ok & (np.abs(err) <= 3.0 * sig))) if n else None,
            "final_errors_kg": [float(x) for x in err],
            "nees_mean": float(np.nanmean(avg_m)) if np.isfinite(avg_m).any() else None,
            "nees_band": [float(lo1), float(hi1)],
            "nees_inside_band_fraction": float(np.mean((avg_m >= lo1) & (avg_m <= hi1))),
            "attitude_nees_mean": float(np.nanmean(avg_a)) if np.isfinite(avg_a).any() else None,
            "attitude_nees_band": [float(lo3), float(hi3)],
            "diverged_runs": diverged,
            "crlb_kg": crlb,
            "crlb_known_model_kg": crlb_known,
            "crlb_parameters_only_kg": crlb_params,
        }
    return out
