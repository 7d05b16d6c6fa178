"""NetCDF files that follow the CF conventions (1.10) and that ``cfchecker`` reads without an error.

Every results file of the package (the trajectory of ``simulate``, ``results.nc``, ``campaign.nc``) goes
through :func:`cf_dataset` and :func:`netcdf_writer`:

- vectors share their dimensions: every ``<name>_component`` dimension whose labels are ``x, y, z`` becomes
  the one dimension ``axis``; ``w, x, y, z`` becomes ``quaternion``; the arm's joint numbers ``arm_joint``;
  a dimension of one label is dropped (the variable is then a plain time series);
- labels (case names, axes, parameter names) are stored as auxiliary coordinates of fixed-length
  characters (``<dim>_name``), the way CF prescribes string-valued coordinates, not as NetCDF-4 variable-length
  strings (which ``cfchecker`` cannot read); the dimension keeps an integer coordinate;
- every variable and coordinate has a ``long_name``, every number a ``units`` (UDUNITS spelling, ``1`` for
  a plain number);
- the global attributes carry ``Conventions = "CF-1.10"``, a ``title``, ``history`` and the provenance of
  :func:`postcapture.io.provenance.provenance` (``postcapture_version``, ``source_commit``, ``command_line``,
  ``date_created``, ``scenario_toml``).

xarray reads such a file back as it would any other: ``ds["attitude_error"].sel(axis=0)`` or, with the
labels, ``ds.set_index(case="case_name")``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["CONVENTIONS", "SHARED_DIMENSIONS", "cf_dataset", "netcdf_writer", "label_index", "labelled"]

CONVENTIONS = "CF-1.10"

SHARED_DIMENSIONS = {
    ("x", "y", "z"): ("axis", "frame axis x, y, z (the frame is named in each variable's name)"),
    ("w", "x", "y", "z"): ("quaternion", "quaternion component, scalar first (w, x, y, z)"),
    ("x", "y", "z", "w"): ("quaternion_xyzw", "quaternion component as Pinocchio stores it, scalar last"),
}
"""Component labels that name a shared dimension, and what it is."""


def _labels(values) -> tuple[str, ...]:
    return tuple(v.decode() if isinstance(v, bytes) else str(v) for v in np.asarray(values).tolist())


def _shared_name(dim: str, labels: tuple[str, ...]) -> tuple[str, str] | None:
    if labels in SHARED_DIMENSIONS:
        return SHARED_DIMENSIONS[labels]
    if labels and all(v.isascii() and v.isdigit() for v in labels) and dim.startswith("arm_"):
        return "arm_joint", "arm joint number, from the base"
    return None


def _share_dimensions(ds):
    """Merge the ``*_component`` dimensions that carry the same labels; drop those of one label."""
    import xarray as xr

    rename, drop = {}, []
    for dim in list(ds.dims):
        if not str(dim).endswith("_component") or dim not in ds.coords:
            continue
        labels = _labels(ds[dim].values)
        if len(labels) == 1:
            drop.append(dim)
        elif (shared := _shared_name(str(dim), labels)) is not None:
            rename[dim] = shared
    if not rename and not drop:
        return ds
    variables, coords, new_dims = {}, {}, {}
    for name, var in ds.variables.items():
        if name in rename or name in drop:
            continue
        for d in drop:
            if d in var.dims:
                var = var.isel({d: 0})
        dims = tuple(rename[d][0] if d in rename else d for d in var.dims)
        new = xr.Variable(dims, var.data, var.attrs, var.encoding)
        (coords if name in ds.coords else variables)[name] = new
    for dim, (new_dim, long_name) in rename.items():
        if new_dim not in new_dims:
            new_dims[new_dim] = (new_dim, list(_labels(ds[dim].values)), {"long_name": long_name})
    coords.update(new_dims)
    return xr.Dataset(variables, coords=coords, attrs=ds.attrs)


def _is_text(values: np.ndarray) -> bool:
    return values.dtype.kind in ("U", "S", "O")


def _labels_as_auxiliary(ds):
    """A dimension labelled by text: integer coordinate ``0..n-1`` plus a ``<dim>_name`` character coordinate."""
    out = ds
    for dim in list(ds.dims):
        if dim in ds.coords and _is_text(ds[dim].values):
            labels = list(_labels(ds[dim].values))
            attrs = dict(ds[dim].attrs)
            long_name = attrs.pop("long_name", str(dim).replace("_", " "))
            out = out.drop_vars(dim).assign_coords({
                dim: (dim, np.arange(len(labels), dtype=np.int32), {"long_name": f"{long_name} (index)",
                                                                    "units": "1"}),
                f"{dim}_name": (dim, labels, {"long_name": f"{long_name} (name)", **attrs}),
            })
    return out


def _describe(ds):
    """Every variable and coordinate with a ``long_name``; every numeric one with ``units``."""
    for name, var in ds.variables.items():
        var.attrs.setdefault("long_name", str(name).replace("_", " "))
        if not _is_text(var.values) and var.dtype.kind in "fiu" and "units" not in var.attrs:
            var.attrs["units"] = "1"
    return ds


def cf_dataset(ds, *, title: str | None = None, provenance: dict | None = None):
    """``ds`` made into a CF-1.10 dataset (see the module docstring); ``ds`` itself is not changed.

    Parameters
    ----------
    ds : xarray.Dataset
    title : str, optional
        The ``title`` attribute (kept from ``ds`` when not given).
    provenance : dict, optional
        :func:`postcapture.io.provenance.provenance`: written as global attributes.
    """
    from postcapture.io.provenance import as_attributes

    out = _describe(_labels_as_auxiliary(_share_dimensions(ds.copy(deep=False))))
    attrs = {k: v for k, v in out.attrs.items() if k != "Conventions"}
    if title is not None:
        attrs["title"] = title
    attrs.setdefault("title", "postcapture results")
    if provenance is not None:
        attrs.update(as_attributes(provenance))
    out.attrs = {"Conventions": CONVENTIONS, **attrs}
    return out


def netcdf_writer(ds) -> Callable[[str], None]:
    """``writer(path)`` writing ``ds`` (a :func:`cf_dataset`) as NetCDF-4 with text as fixed-length characters."""
    encoding = {}
    for name, var in ds.variables.items():
        if _is_text(var.values):
            encoding[name] = {"dtype": "S1", "char_dim_name": f"{name}_strlen"}

    def write(path: str) -> None:
        ds.to_netcdf(path, engine="netcdf4", encoding=encoding)

    return write


def label_index(ds, dim: str, label: str) -> int:
    """The index of ``label`` along ``dim`` in a file written here (``case="dual"`` -> ``case=0``)."""
    names = f"{dim}_name"
    values = _labels(ds[names].values) if names in ds.variables else _labels(ds[dim].values)
    return values.index(label)


def labelled(ds):
    """A dataset read from a file written here, with its text labels back as the dimensions' coordinates
    (``case`` holds ``"dual"``, ``"joint"``, ... again); a dataset that has them already is returned as is."""
    swaps = {}
    for dim in ds.dims:
        name = f"{dim}_name"
        if name in ds.coords and ds[name].dims == (dim,):
            swaps[dim] = list(_labels(ds[name].values))
    if not swaps:
        return ds
    out = ds.drop_vars([f"{d}_name" for d in swaps])
    return out.assign_coords({d: (d, labels, {k: v for k, v in ds[f"{d}_name"].attrs.items() if k != "long_name"}
                                  | {"long_name": ds[f"{d}_name"].attrs.get("long_name", d).removesuffix(" (name)")})
                              for d, labels in swaps.items()})
