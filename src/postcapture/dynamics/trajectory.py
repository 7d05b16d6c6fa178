"""A recorded run: time, states and outputs, and its self-describing NetCDF file."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from postcapture.io.atomic import write_atomic

__all__ = ["StateLayout", "Trajectory"]


@dataclass(frozen=True)
class StateLayout:
    """Names of a run's state and input coordinates, for the NetCDF file.

    Attributes
    ----------
    free_flyer : bool
        The first joint is a free flyer (chaser position and attitude, 7 q and 6 v entries).
    joints : tuple of str
        Names of the one-degree-of-freedom joints, in state order.
    q_index, v_index : tuple of int
        Where each of those joints sits in ``q`` and in ``v``.
    inputs : tuple of (str, str)
        Name and unit of each input channel (``force_x`` (N), ..., ``joint_3_torque`` (N m)); a unit
        of ``""`` means not known.
    """

    free_flyer: bool
    joints: tuple[str, ...]
    q_index: tuple[int, ...]
    v_index: tuple[int, ...]
    inputs: tuple[tuple[str, str], ...]

    @classmethod
    def from_system(cls, system) -> StateLayout | None:
        """The layout of a built :class:`~postcapture.dynamics.system.System`; None for joints it cannot name."""
        from postcapture.config.excitation import CHASER_CHANNELS

        tree = system.tree
        free_flyer = bool(system.layout.free_flyer)
        joints, qi, vi = [], [], []
        for joint in tree.joints[1 if free_flyer else 0 :]:
            if joint.nq != 1 or joint.nv != 1:
                return None
            joints.append(joint.name)
            qi.append(joint.iq)
            vi.append(joint.iv)
        n_arm = system.layout.n_arm
        if free_flyer and system.n_u == 6 + n_arm and not system.custom_input_matrix:
            units = ("N",) * 3 + ("N m",) * 3
            inputs = tuple(zip(CHASER_CHANNELS, units)) + tuple((f"joint_{k + 1}_torque", "N m") for k in range(n_arm))
        else:
            inputs = tuple((f"input_{k + 1}", "") for k in range(system.n_u))
        return cls(free_flyer, tuple(joints), tuple(qi), tuple(vi), inputs)


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
    specs : list of OutputSpec
        Components, unit and description of each output.
    attrs : dict
        Run attributes (scenario, variant, integrator, ...).
    layout : StateLayout, optional
        Names of the state and input coordinates; the NetCDF file splits them into named variables.

    Examples
    --------
    >>> from postcapture.config import load_scenario
    >>> from postcapture.dynamics.simulate import simulate
    >>> simulate(load_scenario("envisat"), duration=1.0)  # doctest: +ELLIPSIS
    Trajectory(scenario 'envisat', flexible model, 11 samples over 1 s, 25 DoF; outputs q_BN, ...)
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    ddq: np.ndarray
    outputs: dict[str, np.ndarray]
    specs: list = field(default_factory=list)
    attrs: dict = field(default_factory=dict)
    layout: StateLayout | None = None

    def __getitem__(self, name: str) -> np.ndarray:
        return self.outputs[name]

    def __contains__(self, name: str) -> bool:
        return name in self.outputs

    def __repr__(self) -> str:
        span = float(self.t[-1] - self.t[0]) if self.t.size else 0.0
        names = list(self.outputs)
        shown = ", ".join(names[:4]) + (", ..." if len(names) > 4 else "")
        return (f"Trajectory(scenario {self.attrs.get('scenario', '?')!r}, {self.attrs.get('variant', '?')} model, "
                f"{self.n} samples over {span:g} s, {self.v.shape[0]} DoF; outputs {shown})")

    @property
    def n(self) -> int:
        """Number of samples."""
        return self.t.size

    def to_dataset(self):
        """An :class:`xarray.Dataset`: every output, input channel and state coordinate as a named variable.

        Units (``units``, UDUNITS/CF syntax) and descriptions (``long_name``) are attributes; time is
        the last dimension of every variable.
        """
        import xarray as xr

        data_vars = {}
        coords = {"time": ("time", self.t, {"units": "s", "long_name": "time since the start of the run"})}
        for spec in self.specs:
            if spec.name == "u" and self.layout is not None and len(self.layout.inputs) == self.outputs["u"].shape[0]:
                for k, (name, unit) in enumerate(self.layout.inputs):
                    data_vars[name] = (("time",), self.outputs["u"][k], _attrs(unit, f"known input {name} "
                                                                                  f"(u[{k}]: {spec.long_name})"))
                continue
            dim = f"{spec.name}_component"
            coords[dim] = (dim, list(spec.components))
            unit = spec.units if spec.name != "u" else ""  # an unsplit input vector mixes N and N m
            data_vars[spec.name] = ((dim, "time"), self.outputs[spec.name], _attrs(unit, spec.long_name))
        if self.layout is not None:
            _state_variables(self, data_vars, coords)
        else:
            for name, values, text in (("q", self.q, "configuration"), ("v", self.v, "velocity"),
                                       ("ddq", self.ddq, "acceleration")):
                dim = "q_index" if name == "q" else "v_index"
                data_vars[name] = ((dim, "time"), values,
                                   {"long_name": f"Pinocchio {text} vector (mixed units: m, rad, 1)"})
        attrs = {k: (v if isinstance(v, (int, float, str)) else str(v)) for k, v in self.attrs.items()}
        if self.layout is not None and self.layout.free_flyer:
            attrs["state_vector"] = ("x = [q, v], q = [state_chaser_position, state_chaser_quaternion, "
                                     "state_joint_angle], v = [state_chaser_velocity, state_chaser_angular_velocity, "
                                     "state_joint_rate] (Pinocchio's order)")
        attrs.setdefault("Conventions", "CF-1.8")
        attrs.setdefault("title", "postcapture truth simulation")
        return xr.Dataset(data_vars, coords=coords, attrs=attrs)

    def to_xarray(self):
        """Same as :meth:`to_dataset`."""
        return self.to_dataset()

    def to_pandas(self):
        """Every output, input channel and state coordinate as a :class:`pandas.DataFrame`, one row per sample.

        Columns are ``name`` for a scalar series and ``name[component]`` for a vector's component (``q_BN[w]``,
        ``omega_BN_B[x]``, ``state_joint_angle[arm_joint_1]``); the index is ``time`` (s). Units are in
        :meth:`to_xarray`'s attributes.
        """
        import pandas as pd

        ds = self.to_dataset()
        columns = {}
        for name, var in ds.data_vars.items():
            if var.dims == ("time",):
                columns[name] = var.values
            else:
                labels = ds[var.dims[0]].values
                for k, label in enumerate(labels):
                    columns[f"{name}[{label}]"] = var.values[k]
        return pd.DataFrame(columns, index=pd.Index(self.t, name="time"))

    def to_netcdf(self, path: str | Path, *, provenance: dict | None = None) -> Path:
        """Write the trajectory as a CF-1.10 NetCDF-4 file (:mod:`postcapture.io.netcdf`), atomically, with its
        provenance (:func:`postcapture.io.provenance.provenance`, made here when not given)."""
        from postcapture.io.netcdf import cf_dataset, netcdf_writer
        from postcapture.io.provenance import provenance as made_by

        ds = cf_dataset(self.to_dataset(), provenance=provenance if provenance is not None else made_by())
        return write_atomic(path, netcdf_writer(ds))


def _attrs(unit: str, long_name: str) -> dict:
    return {"units": unit, "long_name": long_name} if unit else {"long_name": long_name}


def _state_variables(traj: Trajectory, data_vars: dict, coords: dict) -> None:
    """Split q, v and ddq into named variables (chaser position, attitude, rates; one row per joint)."""
    lay = traj.layout
    xyz = ["x", "y", "z"]
    parts = []
    if lay.free_flyer:
        parts += [
            ("state_chaser_position", traj.q[0:3], xyz, "m", "position of the chaser origin in N (q[0:3])"),
            ("state_chaser_quaternion", traj.q[3:7], ["x", "y", "z", "w"], "1",
             "chaser attitude as Pinocchio stores it, scalar last (q[3:7]); q_BN has it scalar first, w >= 0"),
            ("state_chaser_velocity", traj.v[0:3], xyz, "m/s", "linear velocity of the chaser origin, B components (v[0:3])"),
            ("state_chaser_angular_velocity", traj.v[3:6], xyz, "rad/s", "angular velocity of B relative to N, "
             "B components (v[3:6])"),
            ("state_chaser_acceleration", traj.ddq[0:3], xyz, "m/s^2", "time derivative of v[0:3] (spatial "
             "acceleration, B components)"),
            ("state_chaser_angular_acceleration", traj.ddq[3:6], xyz, "rad/s^2", "time derivative of v[3:6]"),
        ]
    for name, values, comps, unit, text in parts:
        dim = f"{name}_component"
        coords[dim] = (dim, comps)
        data_vars[name] = ((dim, "time"), values, _attrs(unit, text))
    if lay.joints:
        coords["joint"] = ("joint", list(lay.joints), {"long_name": "one-degree-of-freedom joint, in state order"})
        qi, vi = list(lay.q_index), list(lay.v_index)
        data_vars["state_joint_angle"] = (("joint", "time"), traj.q[qi], _attrs("rad", "joint angle"))
        data_vars["state_joint_rate"] = (("joint", "time"), traj.v[vi], _attrs("rad/s", "joint rate"))
        data_vars["state_joint_acceleration"] = (("joint", "time"), traj.ddq[vi], _attrs("rad/s^2", "joint acceleration"))
