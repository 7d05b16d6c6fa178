"""The main job's figures: what each file shows, which figure of the reference it answers, and how to draw it.

Every figure is drawn from the results dataset alone (``results.nc``), so it can be redrawn later::

    import xarray as xr
    from postcapture.report.figures import main_job_figures
    figures = main_job_figures(xr.open_dataset("results/results.nc"))
"""

from __future__ import annotations

from dataclasses import dataclass

from matplotlib.figure import Figure

from postcapture.report.attitude import attitude_error_figure, attitude_estimates_figure
from postcapture.report.layout import identical_to
from postcapture.report.mass import mass_error_figure, mass_estimates_figure

__all__ = ["FigureSpec", "FIGURES", "main_job_figures"]


@dataclass(frozen=True)
class FigureSpec:
    """One kind of main-job figure: file stem (``{case}`` is replaced per case), content, reference figure."""

    stem: str
    shows: str
    reference: str


FIGURES = (
    FigureSpec("attitude_estimates", "every case's attitude error angle (10 s RMS, where the estimates, which "
               "coincide with the truth at any readable scale, separate) with its filter's 3σ dotted; one column per "
               "filter model", "4a, 6a"),
    FigureSpec("attitude_error_{case}", "one case's attitude error about each body axis within its filter's ±3σ "
               "(dotted edges); one figure per distinct history, titled with every case that has it", "4b"),
    FigureSpec("mass_estimates", "target-mass estimates with their ±3σ (dotted edges in each case's colour) and the "
               "truth; (a) flexible, (b) stiff filter model", "5a, 5b, 6b"),
    FigureSpec("mass_error", "signed mass error, and its 10 s RMS on a log scale, 1 % and 0.1 % marked; "
               "one column per filter model", "none (ours)"),
)
"""The figures of the main job, in the order they are written."""


def main_job_figures(ds) -> dict[str, Figure]:
    """Every main-job figure, keyed by file stem (``<stem>.png``).

    Parameters
    ----------
    ds : xarray.Dataset
        A main-job results dataset (``postcapture.studies.results.to_dataset``, or ``results.nc``).

    Returns
    -------
    dict of str to matplotlib.figure.Figure
    """
    from postcapture.io.netcdf import labelled

    ds = labelled(ds)  # a file's labels (case names) back on their dimensions
    figures = {
        "attitude_estimates": attitude_estimates_figure(ds),
        "mass_estimates": mass_estimates_figure(ds),
        "mass_error": mass_error_figure(ds),
    }
    same = identical_to(ds, "attitude_error")
    for case in (str(c) for c in ds["case"].values):
        if case not in same:  # one figure per distinct history: its title names the cases that share it
            figures[f"attitude_error_{case}"] = attitude_error_figure(ds, case)
    return figures
