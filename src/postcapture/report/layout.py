"""How the cases of a results dataset are grouped into panels, labelled and titled; display smoothing.

The figures read the :class:`xarray.Dataset` that ``postcapture.studies.results.to_dataset`` builds
(and ``results.nc`` stores): so a figure can be redrawn from the file alone.
"""

from __future__ import annotations

import numpy as np

from postcapture.report.style import MODEL_ORDER, MODEL_TITLES, run_subtitle

__all__ = ["RMS_WINDOW_S", "SAME_RTOL", "moving_rms", "last_before", "model_groups", "model_title", "twins", "identical_to", "subtitle", "divergence_time", "case_label"]


RMS_WINDOW_S = 10.0
"""Window of the moving RMS the figures draw (s)."""

SAME_RTOL = 1e-9
"""Two histories equal to this relative tolerance are drawn as one (labelled "same as")."""


def model_groups(ds) -> list[tuple[str, list[str]]]:
    """``[(filter model, [case, ...]), ...]``: flexible first, then stiff, rigid, others; cases in file order."""
    cases = [str(c) for c in ds["case"].values]
    models = [str(m) for m in ds["filter_model"].values] if "filter_model" in ds.coords else ["flexible"] * len(cases)
    order = [m for m in MODEL_ORDER if m in models] + sorted(set(models) - set(MODEL_ORDER))
    return [(m, [c for c, mc in zip(cases, models) if mc == m]) for m in order]


def model_title(model: str) -> str:
    """Panel title of a filter-model group."""
    return MODEL_TITLES.get(model, f"{model} filter model")


def twins(ds, variable: str) -> dict[str, list[str]]:
    """``{case: [other cases]}``: the cases whose ``variable`` history is the same as each case's.

    "The same" means equal to :data:`SAME_RTOL` relative at every sample, NaN where NaN: far below
    what a figure can show.

    Dual schemes that share a mass filter give identical mass histories; the MEKF does not use the
    plant model, so its attitude is the same on every filter model. The figures say so.
    """
    cases = [str(c) for c in ds["case"].values]
    values = ds[variable].values
    out: dict[str, list[str]] = {c: [] for c in cases}
    for i in range(len(cases)):
        for j in range(i):
            if values[i].shape == values[j].shape and np.allclose(values[i], values[j], rtol=SAME_RTOL, atol=0.0,
                                                                  equal_nan=True):
                out[cases[i]].append(cases[j])
                out[cases[j]].append(cases[i])
    return out


def identical_to(ds, variable: str) -> dict[str, str]:
    """``{case: the first earlier case with exactly the same ``variable`` history}`` (see :func:`twins`)."""
    cases = [str(c) for c in ds["case"].values]
    order = {c: i for i, c in enumerate(cases)}
    same = {}
    for case, others in twins(ds, variable).items():
        earlier = [o for o in others if order[o] < order[case]]
        if earlier:
            same[case] = min(earlier, key=order.get)
    return same


def case_label(case: str, same: dict[str, str]) -> str:
    """Legend label: the case name, and which case it duplicates if any."""
    return f"{case} (same as {same[case]})" if case in same else case


def subtitle(ds) -> str:
    """Scenario, profile, seed, duration and the truth's source of a results dataset, for figure titles."""
    a = ds.attrs
    truth = a.get("truth_source", "nominal")
    truth = "the nominal scenario (the filters' parameters)" if truth in ("nominal", "") else truth
    return run_subtitle(scenario=a.get("scenario", "?"), profile=a.get("profile", "?"), seed=a.get("seed", "?"),
                        duration_s=a.get("duration_s"), plant=a.get("plant"), truth=truth)


def divergence_time(ds, case: str) -> float | None:
    """When the case's filter diverged (s), or None."""
    if "diverged_at" not in ds:
        return None
    value = float(ds["diverged_at"].sel(case=case))
    return value if np.isfinite(value) else None


def moving_rms(t: np.ndarray, x: np.ndarray, window: float) -> np.ndarray:
    """Trailing moving RMS of ``x`` over ``window`` seconds (uniform ``t``); NaN where ``x`` is NaN."""
    x = np.asarray(x, dtype=float)
    dt = float(t[1] - t[0]) if t.size > 1 else 1.0
    w = max(1, int(round(window / dt)))
    finite = np.isfinite(x)
    c = np.concatenate([[0.0], np.cumsum(np.where(finite, x * x, 0.0))])
    n = np.concatenate([[0], np.cumsum(finite)])
    k = np.arange(x.size)
    lo = np.maximum(k + 1 - w, 0)
    count = n[k + 1] - n[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.sqrt((c[k + 1] - c[lo]) / count)
    out[~finite] = np.nan
    return out


def last_before(t: np.ndarray, y: np.ndarray, t_stop: float) -> float | None:
    """The last finite value of ``y`` before ``t_stop`` (where a divergence mark goes), or None."""
    before = y[(t < t_stop) & np.isfinite(y)]
    return float(before[-1]) if before.size else None
