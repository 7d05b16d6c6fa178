"""postcapture: flexible multibody simulation and estimation for the post-capture phase.

A chaser spacecraft holds a large tumbling target (Envisat) through a 7-DoF manipulator with
flexible joints; both spacecraft carry flexible solar panels. The package simulates that system
with a compiled core checked against Pinocchio, generates sensor data, and estimates the chaser attitude
and the target's mass, centre of mass and inertia, also when its model is not the truth.

The short API (see the README, section "Python API"); every function imports what it needs when
called, so ``import postcapture`` stays light:

- :func:`load_scenario`: a validated scenario from a built-in name or a TOML file;
- :func:`simulate`: the truth simulation, a :class:`~postcapture.dynamics.trajectory.Trajectory`;
- :func:`run`: the main job, a :class:`RunResult` (``.table``, ``.to_xarray()``, ``.to_pandas()``), against
  the nominal scenario, another one, or a truth drawn from its priors;
- :func:`campaign`: Monte Carlo over noise seeds and drawn truths, on Dask;
- :func:`calibrate_panel`: a panel's lumped chain against the plate FEM;
- :func:`export_fmu`: the plant as an FMI 2.0 co-simulation FMU.
"""

from postcapture._blas import limit_blas_threads
from postcapture.facade import RunResult, calibrate_panel, campaign, export_fmu, load_scenario, run, simulate

limit_blas_threads()



def __getattr__(name: str):
    """``__version__`` is read from the installed metadata on first use (it costs a few tens of ms)."""
    if name == "__version__":
        from postcapture._version import __version__

        return __version__
    raise AttributeError(f"module 'postcapture' has no attribute {name!r}")


__all__ = ["__version__", "load_scenario", "simulate", "run", "RunResult", "campaign", "calibrate_panel",
           "export_fmu"]
