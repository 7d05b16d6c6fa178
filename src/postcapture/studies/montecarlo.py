"""Monte Carlo campaigns on Dask: many runs of the main job's cases, over noise seeds and drawn truths.

Run ``r`` draws its sensor noise and initial attitude error from the seed ``(scenario seed, r)``; with
``dispersed`` it also draws its truth from the scenario's ``[uncertainty]`` priors with the same seed
(:func:`postcapture.dynamics.truth.draw_truth`), otherwise every run shares one truth (the nominal
scenario, or the given one), simulated once. Every run is a Dask task; results are deterministic, so
a worker that dies loses nothing (the scheduler runs its task again elsewhere) and a campaign gives the
same numbers on any number of workers.

Each finished run is saved at once under ``OUT/runs/`` next to a manifest of the campaign's settings;
started again with the same settings and ``OUT``, a campaign loads what is saved and runs the rest.

The results and their summary: :mod:`postcapture.studies.campaign_result`.

Dask is an optional extra (``pip install 'postcapture[campaign]'``). Without a scheduler address a local
cluster of worker processes is started on 127.0.0.1.
"""

from __future__ import annotations

import dataclasses
import json
import logging
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from postcapture.studies.campaign_result import CampaignResult
from postcapture.studies.cases import CASES
from postcapture.studies.main_job import draw_sensors, run_case, simulate_truth
from postcapture.studies.robust import with_model_noise
from postcapture.studies.setup import RunPlan, plan_run
from postcapture.config.schema import Scenario
from postcapture.core import rotations as rot
from postcapture.core.errors import Problem, ScenarioError
from postcapture.io import write_atomic
from postcapture.studies.checkpoints import save_run, saved_runs, settings_digest
from postcapture.studies.scheduler import MAX_WORKERS, check_scheduler, dask_client
from postcapture.studies.target_estimates import target_errors as _target_errors
from postcapture.dynamics.truth import TruthModel, check_priors, draw_truth, truth_vector_names
from postcapture.estimation.history import StepFlag

__all__ = ["CampaignResult", "run_campaign", "run_one"]

logger = logging.getLogger(__name__)

_MANIFEST = "campaign.json"
_RUNS = "runs"


# ---------------------------------------------------------------------------------------------- one run
def run_one(plan: RunPlan, r: int, dispersed: bool, shared_truth=None) -> dict:
    """Run ``r`` of a campaign: its truth, its sensors, every case; small arrays only (time last)."""
    seed = (plan.seed, int(r))
    if dispersed:
        truth = draw_truth(plan.scenario, seed)
        derived = plan.tuning
        plan = plan_run(plan.scenario, truth=truth, profile=plan.profile_name, duration=plan.duration,
                        cases=plan.cases, initial_mass_error=plan.initial_mass - plan.nominal_mass, seed=plan.seed,
                        plant=plan.plant, mapping=plan.mapping)
        plan = dataclasses.replace(plan, tuning=dataclasses.replace(
            plan.tuning, model_noise=derived.model_noise, discretisation_bias=derived.discretisation_bias))
        traj = simulate_truth(plan)
    else:
        traj = shared_truth
    sensors, dq0 = draw_sensors(plan, traj, seed)
    truth_vec = plan.truth.vector(plan.scenario)
    names = truth_vector_names(plan.scenario)
    m_true = float(truth_vec[names.index("target_mass")])
    q_true = traj["q_BN"]
    out = {"run": int(r), "truth": truth_vec, "true_mass": m_true, "cases": {}}
    for case in plan.cases:
        res = run_case(plan, case, sensors, q_true[:, 0], dq0)
        h = res.attitude
        ok = np.all(np.isfinite(h.q_BN), axis=0)
        e = np.full((3, q_true.shape[1]), np.nan)
        e[:, ok] = rot.box_minus(q_true[:, ok], h.q_BN[:, ok])
        P = h.P[:3, :3, :]
        nees = np.full(e.shape[1], np.nan)
        for k in np.nonzero(ok)[0]:
            nees[k] = e[:, k] @ np.linalg.solve(P[:, :, k], e[:, k])
        diverged = np.nonzero(h.flagged(StepFlag.DIVERGED))[0]
        target = _target_errors(plan, res, truth_vec, names)
        out["cases"][case] = {
            **target,
            "mass_error": res.mass - m_true,
            "mass_sigma": res.mass_sigma,
            "attitude_error": e,
            "attitude_sigma": np.sqrt(np.einsum("iik->ik", P)),
            "attitude_nees": nees,
            "diverged_at": float(h.t[diverged[0]]) if diverged.size else float("nan"),
            "message": h.message,
        }
    return out


def _task(payload: dict, r: int, shared_truth=None) -> dict:
    """Dask task: one run (module level, so it pickles)."""
    import os

    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    return run_one(payload["plan"], r, payload["dispersed"], shared_truth)


# ---------------------------------------------------------------------------------------------- the campaign
def _settings(plan: RunPlan, runs: int, dispersed: bool) -> dict:
    """What identifies a campaign (its manifest): a campaign resumes only into the same settings."""
    return {
        "scenario": plan.scenario.name,
        "scenario_json": plan.scenario.model_dump_json(),
        "truth": plan.truth.source if not dispersed else "drawn per run",
        "truth_json": plan.truth.scenario.model_dump_json() if not dispersed else None,
        "truth_parameters": plan.truth.parameters if not dispersed else None,
        "runs": int(runs),
        "dispersed": bool(dispersed),
        "profile": plan.profile_name,
        "cases": list(plan.cases),
        "duration_s": plan.duration,
        "initial_mass_kg": plan.initial_mass,
        "seed": plan.seed,
    }


def _prepare_out(out: Path, settings: dict, fresh: bool) -> dict[int, dict]:
    """Check or write the manifest; return the valid runs already saved (see :mod:`.checkpoints`)."""
    manifest = out / _MANIFEST
    runs_dir = out / _RUNS
    digest = settings_digest(settings)
    if manifest.exists() and not fresh:
        try:
            saved = json.loads(manifest.read_text())
        except (OSError, ValueError) as exc:
            raise ScenarioError([Problem("--out", "a campaign folder with a readable campaign.json", str(exc))]) from None
        if saved != settings:
            diff = sorted(k for k in set(saved) | set(settings) if saved.get(k) != settings.get(k)) \
                if isinstance(saved, dict) else ["the whole manifest"]
            raise ScenarioError([Problem("--out", f"a new folder, or this campaign's own (its settings differ in "
                                                  f"{', '.join(diff)}); use another --out or --fresh", str(out))])
        return saved_runs(runs_dir, digest=digest, runs=settings["runs"], cases=settings["cases"])
    if fresh and runs_dir.exists():
        for p in runs_dir.glob("run_*.npz"):
            p.unlink()
    runs_dir.mkdir(parents=True, exist_ok=True)
    write_atomic(manifest, lambda tmp: Path(tmp).write_text(json.dumps(settings, indent=1)))
    return {}


def _check_arguments(runs, workers, dispersed, truth, scheduler) -> None:
    problems = []
    if not isinstance(runs, int) or isinstance(runs, bool) or runs < 1:
        problems.append(Problem("runs", "a whole number >= 1", repr(runs)))
    if not isinstance(workers, int) or isinstance(workers, bool) or not 0 <= workers <= MAX_WORKERS:
        problems.append(Problem("workers", f"a whole number in [0, {MAX_WORKERS}]", repr(workers)))
    if dispersed and truth is not None:
        problems.append(Problem("truth", "no fixed truth in a dispersed campaign (each run draws its own)", truth.source))
    if problems:
        raise ScenarioError(problems)
    if scheduler is not None:
        check_scheduler(scheduler)  # an unusable address fails here, before any simulation


def _campaign_plan(scenario, *, truth, profile, duration, cases, initial_mass_error, dispersed, crlb) -> RunPlan:
    """The plan every run shares (model noise derived once), every prior checked."""
    plan = plan_run(scenario, truth=truth, profile=profile, duration=duration, cases=tuple(cases),
                    initial_mass_error=initial_mass_error)
    if crlb or any(CASES[c].scheme in ("dual", "joint") for c in plan.cases):
        plan = with_model_noise(plan)  # once, here: every run's filters share it
    if dispersed:
        check_priors(scenario)
        draw_truth(scenario, (plan.seed, 0))  # a prior that cannot give a physical truth fails here, not in a worker
    return plan


def _run_locally(plan, todo, dispersed, crlb, done_one):
    shared = None if dispersed else simulate_truth(plan)
    for r in todo:
        done_one(run_one(plan, r, dispersed, shared))
    return _crlb(plan) if crlb else None


def _run_on_dask(plan, todo, dispersed, crlb, done_one, scheduler, workers):
    with dask_client(scheduler, workers) as client:
        from dask.distributed import as_completed

        payload = {"plan": plan, "dispersed": dispersed}
        shared = None if dispersed else client.submit(simulate_truth, plan, pure=False)
        futures = [client.submit(_task, payload, r, shared, pure=False) for r in todo]
        crlb_future = client.submit(_crlb, plan, pure=False) if crlb else None
        # as_completed waits on the default client's event loop unless told; a caller with a client of its own
        # (another loop) would make the futures' events refuse the second loop
        for fut in as_completed(futures, loop=client.loop):
            done_one(fut.result())
            fut.release()
        return crlb_future.result() if crlb_future is not None else None


def run_campaign(
    scenario: Scenario,
    *,
    runs: int,
    dispersed: bool = False,
    truth: TruthModel | None = None,
    profile: str = "realistic",
    cases=("dual", "joint"),
    duration: float | None = None,
    initial_mass_error: float | None = None,
    scheduler: str | None = None,
    workers: int = 2,
    out: str | Path | None = None,
    fresh: bool = False,
    crlb: bool = True,
    progress: Callable[[str, float], None] | None = None,
) -> CampaignResult:
    """Run a Monte Carlo campaign (see the module docstring).

    Parameters
    ----------
    scenario : Scenario
        The nominal scenario (the filters' model, the priors, the seed).
    runs : int
        Number of runs.
    dispersed : bool
        Draw each run's truth from the scenario's ``[uncertainty]`` priors.
    truth : TruthModel, optional
        The one truth of a campaign that is not dispersed (the nominal scenario by default).
    profile, cases, duration, initial_mass_error
        As for :func:`postcapture.studies.main_job.run_main_job`.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:port``); a local cluster otherwise.
    workers : int
        Worker processes of the local cluster; 0 runs everything in this process, without Dask.
    out : path, optional
        Folder for the saved runs (resumable); nothing is saved without it.
    fresh : bool
        Discard runs saved in ``out`` by an earlier campaign instead of resuming.
    crlb : bool
        Also compute the mass Cramer-Rao bound on the nominal model.
    progress : callable(task, fraction), optional
        Called with ``("runs", done / runs)`` as runs finish (and once at the start when runs are resumed),
        the one progress signature of the package (:mod:`postcapture.facade`).

    Raises
    ------
    ScenarioError
        For any bad setting, an unusable scheduler address or an ``out`` holding another campaign, before
        anything is simulated.
    """
    wall0 = time.perf_counter()
    _check_arguments(runs, workers, dispersed, truth, scheduler)
    plan = _campaign_plan(scenario, truth=truth, profile=profile, duration=duration, cases=cases,
                          initial_mass_error=initial_mass_error, dispersed=dispersed, crlb=crlb)
    settings = _settings(plan, runs, dispersed)
    digest = settings_digest(settings)
    out_path = Path(out) if out is not None else None
    results: dict[int, dict] = _prepare_out(out_path, settings, fresh) if out_path is not None else {}
    resumed = len(results)
    if resumed:
        logger.warning("resuming: %d of %d runs already saved in %s", resumed, runs, out_path)
        if progress is not None:
            progress("runs", resumed / runs)

    def done_one(res):
        results[res["run"]] = res
        if out_path is not None:
            save_run(out_path / _RUNS, res, digest)
        if progress is not None:
            progress("runs", len(results) / runs)

    todo = [r for r in range(runs) if r not in results]
    crlb_value = None
    if todo or crlb:
        if workers == 0 and scheduler is None:
            crlb_value = _run_locally(plan, todo, dispersed, crlb, done_one)
        else:
            crlb_value = _run_on_dask(plan, todo, dispersed, crlb, done_one, scheduler, workers)
    ordered = [results[r] for r in sorted(results)]
    return CampaignResult(settings, plan.t_grid, ordered, truth_vector_names(scenario), time.perf_counter() - wall0,
                          resumed=resumed, crlb=crlb_value)


def _crlb(plan: RunPlan):
    """The mass Cramer-Rao bounds on the plan's (nominal) truth model and noise (known model, with nuisance)."""
    from postcapture.studies.robust import mass_bounds

    return mass_bounds(plan)
