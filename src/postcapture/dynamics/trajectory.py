"""A recorded run: time, states and outputs, and its self-describing NetCDF file."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from postcapture.io.atomic import write_atomic

__all__ = ["Trajectory"]


@dataclass
class Trajectory:
    """Histories of a run, time as the last axis.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Sample times (s).
    q, v, ddq : ndarray, shapes (nq, n), (nv, n), (nv, n)
        Configuration, velocity and acceleration (Pinocchio layout).
    outputs : dict of str to ndarray (k, n)
        Named outputs (see :func:`postcapture.dynamics.outputs.output_specs`).
    meta : dict
        Output components, units and descriptions, and run attributes (scenario, variant, ...).
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    ddq: np.ndarray
    outputs: dict[str, np.ndarray]
    specs: list = field(default_factory=list)
    attrs: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.outputs[name]

    def __contains__(self, name: str) -> bool:
        return name in self.outputs

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.t.size

    def to_dataset(self):
        """An :class:`xarray.Dataset` with units and descriptions as attributes."""
        import xarray as xr

        data_vars = {}
        coords = {"time": ("time", self.t, {"units": "s", "long_name": "time since the start of the run"})}
        for spec in self.specs:
            dim = f"{spec.name}_component"
            coords[dim] = (dim, list(spec.components))
            data_vars[spec.name] = (
                (dim, "time"),
                self.outputs[spec.name],
                {"units": spec.units, "long_name": spec.long_name},
            )
        data_vars["q"] = (("q_index", "time"), self.q, {"units": "Pinocchio configuration", "long_name": "configuration vector"})
        data_vars["v"] = (("v_index", "time"), self.v, {"units": "Pinocchio velocity", "long_name": "velocity vector"})
        data_vars["ddq"] = (("v_index", "time"), self.ddq, {"units": "Pinocchio acceleration", "long_name": "acceleration vector"})
        attrs = {k: (v if isinstance(v, (int, float, str)) else str(v)) for k, v in self.attrs.items()}
        attrs.setdefault("Conventions", "CF-1.8")
        attrs.setdefault("title", "postcapture truth simulation")
        return xr.Dataset(data_vars, coords=coords, attrs=attrs)

    def to_netcdf(self, path: str | Path) -> Path:
        """Write the trajectory as NetCDF-4 (via xarray), atomically."""
        ds = self.to_dataset()
        return write_atomic(path, lambda tmp: ds.to_netcdf(tmp, engine="netcdf4"))
