"""``FMUProcessModel``: the filters' ProcessModel on any FMI 2.0 / 3.0 co-simulation FMU.

The loop is the reference's (thesis section 4): before ``fmi2DoStep`` the corrected state goes in
(the mapping's correction inputs plus its reset flag, the standard-compliant way to set a state after
initialisation), the FMU advances over ``[t, t + dt]`` with its own integrator and its known inputs,
and the predicted state and measurement are read out. Jacobians come from the FMU's Jacobian outputs,
else its directional derivatives, else finite differences over saved FMU states (see
:mod:`postcapture.fmi.jacobians`). Hot calls go through preallocated buffers
(:class:`postcapture.fmi.slave.RawSlave`).

What the filters read besides attitude and rate comes from the mapping: the chaser's linear velocity
(for a ``free_flyer`` state, ``v[1..3]`` by its layout), the arm's joint angles, the accelerometer's
position, and the inputs holding the plant's parameter vector (``param_names``, ``params``,
``set_params``; the recommended filters need them and their Jacobians ``G``). :meth:`FMUProcessModel.missing`
names what a scheme needs that the FMU and its mapping do not give.

It satisfies :class:`postcapture.estimation.process.ProcessModel`.
"""

from __future__ import annotations

import logging
import shutil
import tempfile
import weakref
from pathlib import Path

import numpy as np

from postcapture.core.errors import DimensionError, DomainError, FMIError
from postcapture.dynamics.parameters import check_parameters, dmass_direction, parameter_names, with_target_mass
from postcapture.estimation.process import Prediction
from postcapture.fmi._extras import import_fmpy
from postcapture.fmi.description import read_description
from postcapture.fmi.jacobians import JACOBIAN_METHODS
from postcapture.fmi.kinematics import make_kinematics
from postcapture.fmi.mapping import Mapping, check_mapping, load_mapping
from postcapture.fmi.slave import Buffer, RawSlave

__all__ = ["FMUProcessModel", "open_model_description", "SCHEMES"]

SCHEMES = ("reference_dual", "dual", "joint")
"""The estimation schemes :meth:`FMUProcessModel.missing` knows what they need."""
_TARGET = parameter_names((), True, False)  # the target hub's ten inertial parameters, in the vector's order

logger = logging.getLogger(__name__)


def open_model_description(path: str | Path):
    """Read an FMU's model description, with typed errors for a missing file or a bad archive."""
    fmpy = import_fmpy()
    path = Path(path)
    if not path.is_file():
        raise FMIError("no such file", fmu=str(path), function="open")
    try:
        return fmpy.read_model_description(str(path), validate=False)
    except Exception as exc:  # FMPy raises plain exceptions for broken archives and XML
        raise FMIError(
            f"cannot read modelDescription.xml: {exc}", fmu=str(path), function="read_model_description"
        ) from exc


def _cleanup(slave_box: list, tmpdir: str) -> None:
    slave = slave_box[0]
    if slave is not None:
        slave.close()
    shutil.rmtree(tmpdir, ignore_errors=True)


class FMUProcessModel:
    """A co-simulation FMU behind the ProcessModel protocol.

    Parameters
    ----------
    path : str or Path
        The ``.fmu`` file.
    mapping : str, Path or Mapping, optional
        The mapping (TOML file or object); default: the FMU's embedded mapping, else ``<fmu>.toml``.
    jacobians : {"auto", "outputs", "directional", "finite_differences"}
        Jacobian strategy; ``auto`` takes the first one the FMU supports in that order.
    name : str, optional
        Label for logs and results (default: the model identifier).
    fd_step : float
        Tangent step of the finite differences (state units).
    fd_mass_step : float
        Relative mass step of the mass derivatives (finite-difference and directional strategies).
    instance_name : str
        FMU instance name.

    Raises
    ------
    FMIError
        Missing file, not a co-simulation FMU, a mapping naming variables the FMU does not have (with
        close matches), or a failed instantiation.
    """

    def __init__(
        self,
        path: str | Path,
        mapping: str | Path | Mapping | None = None,
        *,
        jacobians: str = "auto",
        name: str | None = None,
        fd_step: float = 1e-6,
        fd_mass_step: float = 1e-4,
        instance_name: str = "postcapture",
    ):
        if jacobians != "auto" and jacobians not in JACOBIAN_METHODS:
            raise ValueError(
                f"jacobians: expected auto or one of {sorted(JACOBIAN_METHODS)}, found {jacobians!r}"
            )
        import_fmpy()
        self._init_args = dict(jacobians=jacobians, name=name, fd_step=fd_step, fd_mass_step=fd_mass_step,
                               instance_name=instance_name)
        self.path = Path(path)
        self.label = str(self.path)
        md, cs = self._co_simulation()
        self.model_description = md
        self.mapping = load_mapping(self.path, mapping)
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        idx = {n: i for i, n in enumerate(self.mapping.state)}
        self._check_mapping(idx)
        self.name = name or md.coSimulation.modelIdentifier
        self.fd_step, self.fd_mass_step = float(fd_step), float(fd_mass_step)
        self.nx = len(self.mapping.state)
        self.n = self.kinematics.n
        self.n_meas = self.mapping.n_meas
        self.tangent_attitude = self.kinematics.tangent_attitude
        self.tangent_rate = self.kinematics.tangent_rate
        self.measurement_names = list(self.mapping.accel) + list(self.mapping.joint_accel)
        self._att = np.array([idx[n] for n in self.mapping.attitude])
        self._rate = np.array([idx[n] for n in self.mapping.rate])
        self._sensor_entries(idx)
        self.capabilities = {  # read from the XML itself: FMPy drops FMI 3.0's providesDirectionalDerivatives
            "fmi_version": md.fmiVersion,
            "can_get_and_set_fmu_state": cs.flags["can_get_and_set_fmu_state"],
            "provides_directional_derivative": cs.flags["provides_directional_derivatives"],
            "jacobian_outputs": self.mapping.jacobians is not None,
        }
        self._requested = jacobians
        self._instantiate(instance_name)
        self._open_buffers()

    def _co_simulation(self):
        """The FMU's model description (FMPy's) and its co-simulation interface (ours), checked to be runnable here."""
        md = open_model_description(self.path)
        desc = read_description(self.path)
        cs = desc.interface("co-simulation")
        if cs is None or md.coSimulation is None:
            offered = " and ".join(i.kind for i in desc.interfaces) or "no interface at all"
            raise FMIError(
                f"this FMU offers {offered}; a process model needs the co-simulation interface "
                "(model exchange and FMI 3 scheduled execution are not supported)",
                fmu=self.label,
                function="open",
            )
        unrunnable = desc.binary_problem(cs)
        if unrunnable:
            raise FMIError(unrunnable, fmu=self.label, function="open")
        return md, cs

    def _check_mapping(self, idx: dict) -> None:
        """The mapping's kinematics, and every variable it names checked against the FMU's."""
        try:
            self.kinematics = make_kinematics(
                self.mapping.kinematics,
                len(self.mapping.state),
                [idx[n] for n in self.mapping.attitude],
                [idx[n] for n in self.mapping.rate],
            )
        except ValueError as exc:
            raise FMIError(f"invalid mapping: {exc}", fmu=self.label, function="mapping") from exc
        problems = check_mapping(self.mapping, self.model_description.modelVariables, self.label, self.kinematics.n)
        if problems:
            raise FMIError(
                "the mapping does not match the FMU:\n  - " + "\n  - ".join(problems),
                fmu=self.label,
                function="mapping",
            )

    def _instantiate(self, instance_name: str) -> None:
        """Extract the FMU into a temporary directory and instantiate it; both go when this object does."""
        from fmpy import extract

        self._tmp = tempfile.mkdtemp(prefix="postcapture_fmu_")
        box = [None]
        self._finalizer = weakref.finalize(self, _cleanup, box, self._tmp)
        self._strategy = None
        try:
            unzip = extract(str(self.path), self._tmp)
            self.slave = RawSlave(self.model_description, str(unzip), self.label, instance_name)
        except BaseException:
            self._finalizer()  # remove the extracted files at once
            raise
        box[0] = self.slave

    def _open_buffers(self) -> None:
        """The preallocated buffers of the hot calls, and the start values read through them."""
        vr, m = self.vr, self.mapping
        extra = [vr[m.jacobians.request]] if m.jacobians is not None else []
        self._in = Buffer([vr[n] for n in m.correction] + [vr[m.reset]] + extra)
        self._out = Buffer([vr[n] for n in m.state] + [vr[n] for n in self.measurement_names])
        self._x_only = Buffer([vr[n] for n in m.state])
        self._mass_buf = Buffer([vr[m.mass]]) if m.mass is not None else None
        self._x0 = self.slave.get_real(self._x_only).copy()
        self._mass = float(self.slave.get_real(self._mass_buf)[0]) if self._mass_buf is not None else float("nan")
        self._p_buf = Buffer([vr[n] for n in m.parameters or ()])
        self._params = self.slave.get_real(self._p_buf).copy()

    def _sensor_entries(self, idx: dict) -> None:
        """Where the chaser's linear velocity and the arm's joint angles sit in the state and its tangent."""
        kin, m = self.kinematics, self.mapping
        nq = (self.nx + 1) // 2
        vel = [idx[n] for n in m.velocity] if m.velocity is not None else \
            (list(range(nq, nq + 3)) if kin.name == "free_flyer" else None)
        self._vel = self._arm = None
        self.tangent_velocity = None
        self.tangent_arm = None
        problems = []
        if vel is not None:
            t = [kin.tangent_index(i) for i in vel]
            if None in t or t != list(range(t[0], t[0] + 3)):
                problems.append("[state] velocity: expected three consecutive entries (x, y, z) with tangents of "
                                "their own (not the attitude)")
            else:
                self._vel, self.tangent_velocity = np.array(vel), slice(t[0], t[0] + 3)
        if m.arm is not None:
            arm = [idx[n] for n in m.arm]
            t = [kin.tangent_index(i) for i in arm]
            if None in t:
                problems.append("[state] arm: expected joint angles, found an entry of the root's position or attitude")
            else:
                self._arm, self.tangent_arm = np.array(arm), np.array(t, dtype=int)
        if problems:
            raise FMIError("invalid mapping:\n  - " + "\n  - ".join(problems), fmu=self.label, function="mapping")
        pos = m.accelerometer_position
        self.accelerometer_position = None if pos is None else np.array(pos, dtype=float)
        self.param_names = tuple(m.parameter_names or ())
        self.n_params = len(self.param_names)
        self._hub = [self.param_names.index(n) for n in _TARGET] if set(_TARGET) <= set(self.param_names) else None

    # ------------------------------------------------------------------ lifecycle
    def close(self) -> None:
        """Free the FMU instance and its extracted files (also done when the object is collected)."""
        if self._strategy is not None and hasattr(self._strategy, "close"):
            self._strategy.close(self)
        self._finalizer()
        self.slave = None

    def __enter__(self) -> FMUProcessModel:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ Jacobian strategy
    @property
    def jacobian_method(self) -> str:
        """The strategy ``predict(..., jacobians=True)`` uses (resolved on first use)."""
        return self._resolve().name

    def _resolve(self):
        if self._strategy is not None:
            return self._strategy
        want = self._requested
        jac = self.mapping.jacobians
        complete = jac is not None and (self.mapping.mass is None or jac.g is not None) and (
            not self.n_params or jac.G is not None)
        if want == "auto":
            if complete:  # the outputs give every column this mapping asks for
                want = "outputs"
            elif (
                self.capabilities["provides_directional_derivative"]
                and self.state_derivative_names() is not None
            ):
                want = "directional"
            else:
                want = "finite_differences"
        cls = JACOBIAN_METHODS[want]
        if want == "outputs" and not complete:
            raise FMIError("the mapping names no Jacobian outputs" if jac is None else
                           "the Jacobian outputs lack the mass (g, h) or parameter (G, Hp) columns the mapping needs",
                           fmu=self.label, function="mapping")
        if want == "directional" and not self.capabilities["provides_directional_derivative"]:
            raise FMIError(
                "the FMU does not provide directional derivatives",
                fmu=self.label,
                function="fmi2GetDirectionalDerivative",
            )
        if cls.needs_fmu_state and not self.capabilities["can_get_and_set_fmu_state"]:
            raise FMIError(
                "finite-difference Jacobians need to save and restore the FMU state, and this FMU "
                "cannot (canGetAndSetFMUstate is false); it has no Jacobian outputs or directional "
                "derivatives either",
                fmu=self.label,
                function="fmi2GetFMUstate",
            )
        self._strategy = cls(self)
        return self._strategy

    def state_derivative_names(self) -> list[str] | None:
        """Names of the derivatives of the state variables (ModelStructure/Derivatives), or None."""
        by_state = {}
        for v in self.model_description.modelVariables:
            if v.derivative is not None:
                by_state[v.derivative.name] = v.name
        names = [by_state.get(n) for n in self.mapping.state]
        return None if any(n is None for n in names) else names

    # ------------------------------------------------------------------ protocol
    def copy(self) -> "FMUProcessModel":
        """A new instance of the same FMU and mapping (a filter's own copy of the plant)."""
        return FMUProcessModel(self.path, self.mapping, **self._init_args)

    @property
    def mass(self) -> float:
        """Target mass used by the FMU (kg): the mapping's mass variable, or ``target.m`` plus its offset."""
        if self.mapping.mass_from_parameters and self._hub is not None:
            return float(self._params[self._hub[0]]) + float(self.mapping.mass_offset)
        if self._mass_buf is None:
            raise AttributeError("the mapping names no mass: a mass variable, or parameter inputs with mass_offset")
        return self._mass

    @mass.setter
    def mass(self, value: float) -> None:
        if not np.isfinite(value):
            raise DomainError(f"mass: expected a finite mass (kg), found {value}")
        if self.mapping.mass_from_parameters and self._hub is not None:
            p = self.params
            try:
                p[self._hub] = with_target_mass(p[self._hub], value, float(self.mapping.mass_offset))
            except ValueError as exc:
                raise DomainError(str(exc)) from exc
            self.set_params(p)
            return
        if self._mass_buf is None:
            raise AttributeError("the mapping names no mass: a mass variable, or parameter inputs with mass_offset")
        self._mass_buf.values[0] = float(value)
        self.slave.set_real(self._mass_buf)
        self._mass = float(value)

    def mass_direction(self) -> np.ndarray:
        """``d p / d m`` (n_params,): the hub's mass at a fixed centre of mass and inertia about it."""
        d = np.zeros(self.n_params)
        d[self._hub] = dmass_direction(self._params[self._hub])
        return d

    # ------------------------------------------------------------------ parameters
    @property
    def params(self) -> np.ndarray:
        """The parameter vector the FMU's inputs hold (a copy), in ``param_names``' order."""
        return self._params.copy()

    def set_params(self, p) -> None:
        """Set the parameter inputs (held constant over the next steps).

        Raises
        ------
        DomainError
            For a vector of the wrong size, not finite or, with postcapture's names, not physical (checked
            here: an FMU that refuses a value enters its error state).
        """
        if not self.n_params:
            raise AttributeError("the mapping names no parameter inputs ([parameters] inputs)")
        p = np.array(p, dtype=float).reshape(-1)
        if p.shape != (self.n_params,) or not np.all(np.isfinite(p)):
            raise DomainError(f"parameters: expected {self.n_params} finite numbers ({', '.join(self.param_names)}), "
                              f"found {p}")
        if self.param_names[: len(_TARGET)] == _TARGET:
            p = check_parameters(self.param_names, p, True)
        self._p_buf.values[:] = p
        self.slave.set_real(self._p_buf)
        self._params = p

    def missing(self, scheme: str, parameter_names=(), *, orbit: bool = False) -> list[str]:
        """What a scheme needs that this FMU and its mapping do not give (empty when it can run).

        Parameters
        ----------
        scheme : {"reference_dual", "dual", "joint"}
            The reference's dual scheme (attitude filter and mass filter) or a recommended one.
        parameter_names : sequence of str
            The parameters the recommended schemes estimate or consider (postcapture's names).
        orbit : bool
            Whether the filters model the orbit's gravity gradient (they then read the chaser's position).

        Returns
        -------
        list of str
            One entry per missing item, naming the mapping entry or FMU capability.
        """
        if scheme not in SCHEMES:
            raise ValueError(f"scheme: expected one of {', '.join(SCHEMES)}, found {scheme!r}")
        need = []
        if self._vel is None:
            need.append("[state] velocity: the chaser's linear velocity (B frame, m/s) in the state")
        if self.accelerometer_position is None:
            need.append("[measurement] accelerometer_position: where the accelerometer sits in B (m)")
        if orbit and scheme != "reference_dual" and self.kinematics.name != "free_flyer":
            need.append("the chaser's position (a free_flyer state): the filters model the orbit's field")
        if scheme == "reference_dual":
            if self._mass_buf is None and not (self.mapping.mass_from_parameters and self._hub is not None):
                need.append("[parameters] mass: a variable that is the target's mass, or inputs with mass_offset")
            return need
        if self._arm is None:
            need.append("[state] arm: the arm's joint angles (rad) in the state (the encoders read them)")
        absent = [n for n in parameter_names if n not in self.param_names]
        if absent:
            need.append(f"[parameters] inputs: inputs holding {', '.join(absent)}")
        jac = self.mapping.jacobians
        derivable = (jac is not None and jac.G is not None) or self.capabilities["can_get_and_set_fmu_state"] or (
            self.capabilities["provides_directional_derivative"] and self.state_derivative_names() is not None)
        if not derivable:
            need.append("the parameter Jacobians: G and Hp outputs, directional derivatives or saved FMU states")
        return need

    def initial_state(self) -> np.ndarray:
        """The FMU's state after initialisation (its start values), shape (nx,)."""
        return self._x0.copy()

    def _raw_step(self, x: np.ndarray, t: float, dt: float, request: bool = False):
        vals = self._in.values
        vals[: self.nx] = x
        vals[self.nx] = 1.0
        if self._in.n > self.nx + 1:
            vals[self.nx + 1] = 1.0 if request else 0.0
        self.slave.set_real(self._in)
        self.slave.do_step(t, dt)
        out = self.slave.get_real(self._out)
        return out[: self.nx].copy(), out[self.nx :].copy()

    def predict(self, x, t: float, dt: float, jacobians: bool = False):
        """Advance ``x`` (nx,) from ``t`` to ``t + dt`` (s) and predict the measurement there.

        Returns
        -------
        Prediction
            ``x`` (nx,), ``z`` (n_meas,) and, with ``jacobians=True``, ``F`` (n, n), ``g`` (n,),
            ``H`` (n_meas, n), ``h`` (n_meas,) in tangent coordinates, and ``G`` (n, n_params), ``Hp``
            (n_meas, n_params) when the mapping names parameter inputs (``g``, ``h`` None without a mass).

        Raises
        ------
        FMIError
            When a call fails (``fmi2DoStep`` returning Discard or Error, ...), or the FMU is in the
            error state after an earlier failure.
        DimensionError, DomainError
            For ``x`` of the wrong shape or not finite, or ``t``, ``dt`` not finite or ``dt <= 0``.
        """
        if self.slave is None:
            raise FMIError("the process model is closed", fmu=self.label, function="predict")
        x = np.asarray(x, dtype=float)
        if x.shape != (self.nx,):
            raise DimensionError(f"x: expected shape ({self.nx},), found {x.shape}")
        if not np.all(np.isfinite(x)):
            bad = [self.mapping.state[i] for i in np.flatnonzero(~np.isfinite(x))[:3]]
            raise DomainError(f"x: expected finite values, found non-finite {', '.join(bad)}")
        if not (np.isfinite(t) and np.isfinite(dt) and dt > 0):
            raise DomainError(f"t, dt: expected a finite time and a finite step > 0 s, found t = {t}, dt = {dt}")
        if not jacobians:
            x1, z = self._raw_step(x, t, dt)
            return Prediction(x1, z)
        strategy = self._resolve()
        if strategy.needs_fmu_state:
            strategy.save_before(self)
        x1, z = self._raw_step(x, t, dt, request=strategy.uses_request)
        F, g, H, h, G, Hp = strategy.compute(self, x, t, dt, x1, z)
        return Prediction(x1, z, F, g, H, h, G, Hp)

    def retract(self, x, dx) -> np.ndarray:
        """``x (+) dx`` (box-plus), shape (nx,)."""
        return self.kinematics.retract(np.asarray(x, dtype=float), np.asarray(dx, dtype=float))

    def local(self, x1, x0) -> np.ndarray:
        """``x1 (-) x0`` (box-minus), shape (n,)."""
        return self.kinematics.local(np.asarray(x1, dtype=float), np.asarray(x0, dtype=float))

    def attitude(self, x) -> np.ndarray:
        """Chaser attitude ``q_BN`` (w, x, y, z), ``w >= 0``."""
        q = np.asarray(x, dtype=float)[self._att]
        return -q if q[0] < 0 else q

    def body_rate(self, x) -> np.ndarray:
        """Chaser body rate ``omega_BN_B`` (rad/s)."""
        return np.asarray(x, dtype=float)[self._rate]

    def chaser_position(self, x) -> np.ndarray:
        """Position of the chaser's origin in N (m): a free-flyer state's first entries."""
        if self.kinematics.name != "free_flyer":
            raise FMIError("the chaser's position is known for a free_flyer state only", fmu=self.label,
                           function="mapping")
        return np.asarray(x, dtype=float)[0:3]

    def chaser_velocity(self, x) -> np.ndarray:
        """Velocity of the chaser's origin, body components (m/s)."""
        if self._vel is None:
            raise FMIError("the mapping names no [state] velocity (the chaser's linear velocity)", fmu=self.label,
                           function="mapping")
        return np.asarray(x, dtype=float)[self._vel]

    def arm_angles(self, x) -> np.ndarray:
        """The arm's joint angles (rad)."""
        if self._arm is None:
            raise FMIError("the mapping names no [state] arm (the arm's joint angles)", fmu=self.label,
                           function="mapping")
        return np.asarray(x, dtype=float)[self._arm]
