"""Monte Carlo campaigns on Dask: one truth, many sensor-noise seeds, filter consistency.

The truth is simulated once and scattered to the workers; each task draws its sensor noise and
initial attitude error from its own seed and runs the requested cases. The consistency check is
Bar-Shalom's: the attitude NEES averaged over the N runs at each instant should lie in the two-sided
95 % chi-square band ``chi2.ppf([0.025, 0.975], 3 N) / N`` (and its time average too).

Dask is an optional extra (``pip install 'postcapture[campaign]'``). Without a scheduler address a
local cluster of worker processes is started; give ``scheduler="tcp://host:8786"`` for a real one.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from postcapture.campaign.main_job import _run_case
from postcapture.campaign.cases import CASES, attitude_P0
from postcapture.campaign.sensing import measure_all, resolve_profile
from postcapture.config.schema import Scenario
from postcapture.core import rotations as rot
from postcapture.core.consistency import chi2_bounds
from postcapture.core.errors import MissingExtraError, Problem, ScenarioError
from postcapture.dynamics.simulate import simulate

__all__ = ["MonteCarloResult", "monte_carlo"]


@dataclass
class MonteCarloResult:
    """Per-case consistency over the seeds."""

    seeds: list
    t: np.ndarray
    nees: dict  # case -> (n_seeds, n_t) attitude NEES
    mass_error: dict  # case -> (n_seeds, n_t) kg
    mass_sigma: dict  # case -> (n_seeds, n_t) kg
    wall_s: float

    def summary(self) -> dict:
        """Mean NEES over seeds and time, the share of instants inside the band, mass statistics."""
        n = len(self.seeds)
        lo, hi = chi2_bounds(3, n)
        out = {"n_seeds": n, "nees_band_95": [lo, hi], "cases": {}, "wall_s": self.wall_s}
        for name, nees in self.nees.items():
            avg = np.nanmean(nees, axis=0)
            err = self.mass_error[name][:, -1]
            out["cases"][name] = {
                "nees_mean": float(np.nanmean(avg[1:])),
                "nees_inside_band": float(np.mean((avg[1:] >= lo) & (avg[1:] <= hi))),
                "final_mass_error_mean_kg": float(np.mean(err)),
                "final_mass_error_std_kg": float(np.std(err, ddof=1)) if n > 1 else float("nan"),
                "final_mass_sigma_mean_kg": float(np.mean(self.mass_sigma[name][:, -1])),
            }
        return out


def _seed_task(truth_data: dict, base: dict, seed: int, cases) -> dict:
    """Worker: sensors from this seed, then every case; returns small arrays only."""
    rng = np.random.default_rng(seed)
    truth = truth_data["traj"]
    sensors = measure_all(truth, base["profile"], rng)
    dq0 = np.linalg.cholesky(base["P0"]) @ rng.standard_normal(3)
    out = {}
    for case in cases:
        _, res = _run_case({**base, "sensors": sensors, "dq0": dq0, "case": case}, None)
        h = res.attitude
        ok = np.all(np.isfinite(h.q_BN), axis=0)
        e = np.full((3, truth.t.size), np.nan)
        e[:, ok] = rot.box_minus(truth["q_BN"][:, ok], h.q_BN[:, ok])
        P = h.P[:3, :3, :]
        nees = np.array([e[:, k] @ np.linalg.solve(P[:, :, k], e[:, k]) if ok[k] else np.nan for k in range(e.shape[1])])
        out[case] = (nees, res.mass - base["m_true"], res.mass_sigma)
    return out


def monte_carlo(
    scenario: Scenario,
    *,
    profile: str = "realistic",
    cases=("ekf_flexible", "mekf_flexible"),
    seeds=range(50),
    duration: float | None = None,
    scheduler: str | None = None,
    n_workers: int = 2,
    progress: Callable[[float], None] | None = None,
) -> MonteCarloResult:
    """Run ``cases`` for every seed of sensor noise on one truth, on Dask.

    Parameters
    ----------
    scenario : Scenario
    profile : {"reference", "realistic"}
    cases : sequence of str
    seeds : iterable of int
    duration : float, optional
    scheduler : str, optional
        Address of a running Dask scheduler; a local cluster of ``n_workers`` processes otherwise.
    n_workers : int
    progress : callable(fraction), optional
    """
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError as exc:
        raise MissingExtraError("dask[distributed]", "campaign") from exc
    bad = [c for c in cases if c not in CASES]
    if bad:
        raise ScenarioError([Problem("cases", f"names among {', '.join(CASES)}", ", ".join(bad))])
    wall0 = time.perf_counter()
    seeds = [int(s) for s in seeds]
    truth = simulate(scenario, duration=duration)
    prof = resolve_profile(scenario, profile)
    m_true = float(scenario.target.mass)
    base = {"scenario": scenario.model_dump(), "t_grid": truth.t, "profile": prof, "profile_name": profile,
            "theta0": m_true + scenario.estimation.initial_mass_error, "q_true0": truth["q_BN"][:, 0],
            "P0": attitude_P0(prof, profile), "m_true": m_true}
    cluster = None
    if scheduler is None:
        cluster = LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, dashboard_address=None)
        client = Client(cluster)
    else:
        client = Client(scheduler)
    try:
        truth_ref = client.scatter({"traj": truth}, broadcast=True)
        futures = [client.submit(_seed_task, truth_ref, base, s, tuple(cases), pure=False) for s in seeds]
        index = {f.key: i for i, f in enumerate(futures)}
        results: list = [None] * len(seeds)
        for done, fut in enumerate(as_completed(futures), start=1):
            results[index[fut.key]] = fut.result()
            if progress is not None:
                progress(done / len(futures))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    nees = {c: np.array([r[c][0] for r in results]) for c in cases}
    merr = {c: np.array([r[c][1] for r in results]) for c in cases}
    msig = {c: np.array([r[c][2] for r in results]) for c in cases}
    return MonteCarloResult(seeds, truth.t, nees, merr, msig, time.perf_counter() - wall0)
