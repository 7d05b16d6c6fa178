r"""The model-based augmented EKF: plant state, sensor biases and plant parameters in one error state.

Error state (named by :attr:`AugmentedEKF.labels`)::

    [ dx (n: the plant's tangent) | db_gyro (3) | db_accel (3) | d gyro calibration (0 or 9) |
      d eta (estimated) | d eta (considered) | clone (9) ]

``eta`` are the filter's coordinates of the plant's parameters (:class:`~postcapture.estimation.
parameters.ParameterMap`: log-Cholesky for the target's inertial parameters, logarithms of factors).
Estimated coordinates are updated by the measurements; *considered* ones (Schmidt-Kalman) keep their
nominal value, but their covariance and their cross-covariance with everything else are carried, so the
filter's uncertainty covers what they do to the predictions. The gyro calibration (when the tuning gives
it a prior) is the three scale-factor errors and the six misalignments of the gyro triad (row-major
off-diagonal terms of ``M``; the gyro reads ``(I + diag(s) + M) omega``).

Prediction: the plant copy advances with the current parameters and its exact step Jacobians,
``Phi = [[F, G dp/deta], [0, I]]``; the biases are random walks; the plant's coordinates get the model
error process noise ``model_noise`` per step. Before the step, the chaser's attitude, linear velocity
and body rate (their errors and values) are *cloned* (stochastic cloning), so that the inertial sensors'
increments over the step (:mod:`postcapture.estimation.increments`: the mean rate and the mean specific
force, both exact functions of the clone and the predicted state) are ordinary measurements with exact
Jacobians.

Measurements: the star tracker (``H = I`` on the attitude), the gyro's mean rate (reads its bias and
calibration), the accelerometer's mean specific force at its position in B (reads its bias) and the arm's
encoders (``H = I`` on the joint angles).

The filter runs in the compiled engine (``pc_augmented.c``): prediction, measurement models, update,
recovery. Over a native process model (one with ``engine_handles``) it steps its plant copy's own instance
there (``pc_model_t`` shared, ``pc_data_t`` its own). Over any other process model (an FMU) the engine's
filter has no plant: each prediction sets the model's parameters to the engine's ``p(eta)``, asks the model
for its step with ``F = d x1 / d x`` and ``G = d x1 / d p`` (``predict(..., jacobians=True)``) and hands
them to the engine, which runs the same propagation as over its own instance. The model must then have
the native state's layout (a free-flyer root, quaternion x y z w at ``x[3:7]``, then Euclidean joints and
the velocities) and parameter inputs (``param_names``, ``params``, ``set_params``). Either way a step the
plant cannot take is a divergence (re-initialised, tried again) and a second failure raises.

This class sets the filter up (the labels, the initial state and covariance from the prior) and exposes its
state; the filter equations are the engine's only.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass, field

import numpy as np

from postcapture.core import kalman
from postcapture.core import rotations as rot
from postcapture.core.errors import DomainError, FMIError, SimulationError
from postcapture.core.triad import CALIBRATION_LABELS
from postcapture.dynamics import engine as _engine
from postcapture.estimation.filter import FilterBase, Measurement, RecoveryPolicy, state_view
from postcapture.estimation.parameters import ParameterMap

__all__ = ["AugmentedTuning", "AugmentedEKF", "AugmentedSetup"]


@dataclass(frozen=True)
class AugmentedTuning:
    """Noise model of the augmented EKF (SI units; variances per axis unless stated).

    Parameters
    ----------
    R_star : ndarray (3, 3)
        Star-tracker covariance (rad^2).
    sigma_gyro_bias_walk : float
        Gyro bias random walk (rad/s^1.5).
    sigma_accel_bias_walk : float
        Accelerometer bias random walk (m/s^2.5).
    P0_attitude : ndarray (3, 3)
    P0_gyro_bias, P0_accel_bias : float
    P0_state : float
        Initial variance of every other plant coordinate, on top of what the parameters imply.
    model_noise : float, ndarray (nv,) or ndarray (n, n)
        Process noise added per step to the plant: one variance for every velocity coordinate, one per
        velocity coordinate ((rad/s)^2 or (m/s)^2), or a full covariance over the plant's tangent: the
        model error the parameters do not describe.
    P0_gyro_scale, P0_gyro_misalignment : float
        Prior variances of the gyro's scale-factor errors (relative) and misalignments (rad^2); both 0
        (the default): the filter carries no calibration states.
    mean_motion : float
        Of the orbit whose tidal field the accelerometer's model takes out (rad/s; 0: free space).
    gate_probability : float or None
    recovery : RecoveryPolicy
    """

    R_star: np.ndarray
    sigma_gyro_bias_walk: float
    sigma_accel_bias_walk: float
    P0_attitude: np.ndarray
    P0_gyro_bias: float
    P0_accel_bias: float
    P0_state: float = 1e-16
    model_noise: float | np.ndarray = 0.0
    P0_gyro_scale: float = 0.0
    P0_gyro_misalignment: float = 0.0
    mean_motion: float = 0.0
    gate_probability: float | None = 0.9999
    recovery: RecoveryPolicy = field(default_factory=RecoveryPolicy)

    @property
    def gyro_calibration(self) -> bool:
        """Whether the filter carries the gyro's scale factors and misalignments."""
        return self.P0_gyro_scale > 0.0 or self.P0_gyro_misalignment > 0.0



@dataclass(frozen=True)
class AugmentedSetup:
    """What the engine's filter was created from (an estimator FMU embeds it): the plant state before the
    initial attitude estimate ``q0_BN`` is applied, then ``dx_shift`` (tangent) that moves it to the prior's
    parameters; the prior's coordinates and covariance; the model noise per velocity (or full)."""

    x0: np.ndarray
    q0_BN: np.ndarray | None
    dx_shift: np.ndarray
    eta0: np.ndarray
    P0: np.ndarray
    q_noise: np.ndarray
    full_noise: bool
    n_cal: int
    n_consider: int


_PLANT_FAILURES = (SimulationError, DomainError, FMIError)
"""What a plant stepping outside the engine raises for a step it cannot take (or parameters it refuses)."""


def _check_layout(model, name: str) -> None:
    """Refuse a model whose state is not laid out as the engine's filter reads it (the native plant's:
    ``x = [q (nq), v (nv)]``, a free flyer's position and quaternion x y z w in ``q[:7]``, the tangent
    ``[dq (nv), dv (nv)]``) or that gives no parameter inputs."""
    missing = [a for a in ("param_names", "params", "set_params") if not hasattr(model, a)]
    if missing or not getattr(model, "param_names", ()):
        raise TypeError(f"{name}: the augmented EKF estimates the plant's parameters; {type(model).__name__} gives "
                        f"no parameter inputs ({', '.join(missing) or 'param_names is empty'})")
    n, nx = int(model.n), int(model.nx)
    nv = n // 2
    nq = nx - nv
    problems = []
    if n % 2 or nq != nv + 1 or nv < 6:
        problems.append(f"sizes nx = {nx}, n = {n} (expected nx = 2 nv + 1, n = 2 nv, nv >= 6)")
    else:
        want = {"tangent_attitude": slice(3, 6), "tangent_velocity": slice(nv, nv + 3),
                "tangent_rate": slice(nv + 3, nv + 6)}
        problems += [f"{k} = {getattr(model, k, None)} (expected {v})" for k, v in want.items()
                     if getattr(model, k, None) != v]
        probe = 1.0 + np.arange(nx, dtype=float)  # distinct entries: which the model's readers pick
        arm = np.asarray(() if model.tangent_arm is None else model.tangent_arm, dtype=int) + (nq - nv)
        reads = {"attitude": (model.attitude, probe[[6, 3, 4, 5]]), "chaser_velocity": (model.chaser_velocity,
                 probe[nq:nq + 3]), "body_rate": (model.body_rate, probe[nq + 3:nq + 6])}
        if arm.size:
            reads["arm_angles"] = (model.arm_angles, probe[arm])
        for k, (read, native) in reads.items():
            try:
                same = np.array_equal(np.asarray(read(probe), dtype=float), native)
            except Exception as exc:  # a reader that cannot read it is a layout problem too
                problems.append(f"{k}: {exc}")
                continue
            if not same:
                problems.append(f"{k} does not read the native entries")
    if problems:
        raise TypeError(f"{name}: the augmented EKF reads the native plant's state layout (a free-flyer root, its "
                        f"quaternion x y z w at x[3:7], then the joints and the velocities); {type(model).__name__} "
                        f"{getattr(model, 'name', '')}: " + "; ".join(problems))


class AugmentedEKF(FilterBase):
    """See the module docstring.

    Parameters
    ----------
    model : ProcessModel
        The filter's own plant copy (with ``param_names``, ``params``, ``set_params``): a native one (with
        ``engine_handles``) or any other with the native state's layout (see the module docstring).
    x0 : ndarray (nx,)
        Initial plant state, for the nominal parameters ``model.params``.
    params : ParameterMap
        Coordinates of the estimated groups followed by the considered ones.
    n_consider : int
        How many of ``params``' last coordinates are considered.
    eta0 : ndarray
        Initial coordinates (estimated and considered).
    P_eta : ndarray
        Their initial covariance.
    S0 : ndarray (n, n_p)
        Derivative of the initial plant state with respect to the parameters (``x0 = x0(p)``).
    tuning : AugmentedTuning
    q0_BN : ndarray (4,), optional
        Initial attitude estimate (replaces ``x0``'s).
    name : str
    """

    _S_PREFIX = True
    _KIND = {"star_tracker": 0, "gyro": 1, "accelerometer": 2, "encoders": 3}

    def __init__(self, model, x0, *, params: ParameterMap, n_consider: int, eta0, P_eta, S0, tuning: AugmentedTuning,
                 q0_BN=None, name: str = "joint"):
        self._init_base(name, tuning.recovery, tuning.gate_probability)
        self.model = model
        self._outside = not hasattr(model, "engine_handles")  # the model steps in Python (an FMU), not the engine
        if self._outside:
            _check_layout(model, name)
        self.tuning = tuning
        self.params = params
        self._layout(n_consider)
        x, eta, P, x_start, dx_shift = self._initial(x0, eta0, P_eta, S0, q0_BN)
        n, ncal = self.n, self.i_cal.stop - self.i_cal.start
        noise = np.asarray(tuning.model_noise, dtype=float)
        full = noise.ndim == 2
        q_noise = np.ascontiguousarray(noise if full else np.broadcast_to(noise, (n // 2,)), dtype=float)
        self.setup = AugmentedSetup(x_start, None if q0_BN is None else np.array(q0_BN, dtype=float), dx_shift, eta,
                                    P, q_noise, full, ncal, n_consider)
        self._create(x, eta, P, q_noise, full, ncal, n_consider)

    def _layout(self, n_consider: int) -> None:
        """Where each part of the error state sits, and its labels."""
        model, params = self.model, self.params
        n = model.n
        self.n = n
        self.att = model.tangent_attitude
        k = params.size
        ncal = 9 if self.tuning.gyro_calibration else 0
        self.i_bg = slice(n, n + 3)
        self.i_ba = slice(n + 3, n + 6)
        self.i_cal = slice(n + 6, n + 6 + ncal)
        e0 = n + 6 + ncal
        self.i_eta = slice(e0, e0 + k)
        self.i_est = slice(e0, e0 + k - n_consider)
        self.i_con = slice(e0 + k - n_consider, e0 + k)
        self.i_clone = slice(e0 + k, e0 + k + 9)
        self.N = self.i_clone.stop
        self.i_arm = np.asarray(model.tangent_arm, dtype=int)
        self.r_accel = np.asarray(model.accelerometer_position, dtype=float)
        labels = [f"plant[{i}]" for i in range(n)]
        for i, axis in zip(range(self.att.start, self.att.stop), "xyz"):
            labels[i] = f"dtheta_{axis}"
        labels += [f"gyro_bias_{a}" for a in "xyz"] + [f"accel_bias_{a}" for a in "xyz"]
        if ncal:
            labels += [f"gyro_{label}" for label in CALIBRATION_LABELS]
        labels += list(params.labels)
        labels += [f"clone_{q}_{a}" for q in ("dtheta", "v", "omega") for a in "xyz"]
        self.labels = tuple(labels)

    def _initial(self, x0, eta0, P_eta, S0, q0_BN):
        """The initial state (with the attitude estimate, then moved to the prior's parameters) and covariance:
        ``(x, eta, P, x before both, the move dx_shift)``."""
        model, params, tuning, n, N = self.model, self.params, self.tuning, self.n, self.N
        eta = np.array(eta0, dtype=float)
        x = np.array(x0, dtype=float)
        x_start = x.copy()
        if q0_BN is not None:
            d = np.zeros(n)
            d[self.att] = rot.box_minus(np.asarray(q0_BN, dtype=float), model.attitude(x))
            x = model.retract(x, d)
        # the initial state follows the parameters it was computed with: move it to eta0, first order
        p0 = params.to_model(eta)
        model.set_params(p0)
        dx_shift = S0 @ (p0 - params.p_nominal)
        x = model.retract(x, dx_shift)
        P = np.zeros((N, N))
        P[:n, :n] = tuning.P0_state * np.eye(n)
        P[self.att, self.att] = tuning.P0_attitude
        P[self.i_bg, self.i_bg] = tuning.P0_gyro_bias * np.eye(3)
        P[self.i_ba, self.i_ba] = tuning.P0_accel_bias * np.eye(3)
        if self.i_cal.stop > self.i_cal.start:
            P[self.i_cal, self.i_cal] = np.diag([tuning.P0_gyro_scale] * 3 + [tuning.P0_gyro_misalignment] * 6)
        P[self.i_eta, self.i_eta] = P_eta
        Sx = S0 @ params.jacobian(eta)  # d x0 / d eta
        P[:n, :n] += Sx @ P_eta @ Sx.T
        P[:n, self.i_eta] = Sx @ P_eta
        P[self.i_eta, :n] = P[:n, self.i_eta].T
        return x, eta, kalman.symmetrize(P), x_start, dx_shift

    def _create(self, x, eta, P, q_noise, full: bool, ncal: int, n_consider: int) -> None:
        model, tun = self.model, self.tuning
        arm_v = np.ascontiguousarray(self.i_arm, dtype=np.int32)
        spec = self.params.spec
        p_nom = np.ascontiguousarray(self.params.p_nominal, dtype=float)
        ip, dp = ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_double)
        cfg = _engine.AugConfigStruct(arm_v.size, ncal, n_consider, int(full), spec.size, arm_v.ctypes.data_as(ip),
                                      spec.ctypes.data_as(ip), p_nom.ctypes.data_as(dp),
                                      float(getattr(model, "step", 0.0)),
                                      (ctypes.c_double * 3)(*self.r_accel), tun.sigma_gyro_bias_walk,
                                      tun.sigma_accel_bias_walk, float(tun.mean_motion),
                                      int(getattr(model, "jacobian", "every_step") == "first_step"))
        err = ctypes.create_string_buffer(512)
        args = (ctypes.byref(cfg), np.ascontiguousarray(x), np.ascontiguousarray(eta), np.ascontiguousarray(P),
                q_noise, ctypes.byref(self._policy(max(3, arm_v.size))), err, len(err))
        if self._outside:
            nv = self.n // 2
            handle = self._eng.aug_create_external(x.size - nv, nv, p_nom.size, *args)
        else:
            handle = self._eng.aug_create(*model.engine_handles(), *args)
        if not handle:
            raise ValueError(f"{self.name}: {err.value.decode(errors='replace')}")
        self._attach(handle)
        st, nx, N, k = self._state, x.size, self.N, eta.size
        self._x, self._bg, self._ba = st[:nx], st[nx:nx + 3], st[nx + 3:nx + 6]
        o = nx + 6
        self._cal, self._eta = st[o:o + ncal], st[o + ncal:o + ncal + k]
        o += ncal + k
        self._cq, self._cv, self._cw = st[o:o + 4], st[o + 4:o + 7], st[o + 7:o + 10]
        self._dt_t = st[o + 10:o + 12]
        self._P = st[o + 12:].reshape(N, N)
        self._C_buf = np.zeros((self.params.p_nominal.size,) * 2)
        # an update's sample and covariance are copied into these (allocated once: their addresses are taken once)
        n_arm = self.i_arm.size
        self._in_value, self._in_R = np.zeros(max(4, n_arm)), np.zeros(max(3, n_arm) ** 2)
        shapes = {0: (4, 3), 1: (3, 3), 2: (3, 3), 3: (n_arm, n_arm)}  # by kind: the sample's size, R's side
        self._in_views = {k: (self._in_value[:n], self._in_R[:r * r].reshape(r, r)) for k, (n, r) in shapes.items()}
        self._addr.update(value=self._in_value.ctypes.data, R=self._in_R.ctypes.data)
        self._update_call = self._eng.by_address("aug_update")

    # ------------------------------------------------------------------ the state (the engine's)
    x = state_view("_x", "The plant copy's state (a copy; assigning writes the engine's).")
    eta = state_view("_eta", "Parameter coordinates, estimated then considered.")
    gyro_bias = state_view("_bg", "Gyro-bias estimate (rad/s).")
    accel_bias = state_view("_ba", "Accelerometer-bias estimate (m/s^2).")
    gyro_cal = state_view("_cal", "Gyro calibration estimate (scale factors, misalignments; empty when none).")

    def _measurement_model(self, kind: str):
        """The engine's predicted measurement of a kind (gyro, accelerometer, encoders) and its Jacobian (m, N)."""
        m = self.i_arm.size if kind == "encoders" else 3
        z, H = np.zeros(m), np.zeros((m, self.N))
        self._eng.aug_measure(self._handle, self._KIND[kind], z, H)
        return z, H

    def _apply(self, dx) -> None:
        """``x <- x (+) dx`` over the whole error state (the engine's correction)."""
        self._eng.aug_apply(self._handle, np.ascontiguousarray(dx, dtype=float))

    @property
    def _clone(self):
        """The chaser's attitude, velocity and rate at the cycle's start (the cloned values)."""
        return self._cq.copy(), self._cv.copy(), self._cw.copy()

    @_clone.setter
    def _clone(self, values) -> None:
        q, v, w = values
        self._cq[:], self._cv[:], self._cw[:] = q, v, w

    def _clone_values(self, x):
        m = self.model
        return m.attitude(x), m.chaser_velocity(x), m.body_rate(x)

    @property
    def _dt(self) -> float | None:
        return float(self._dt_t[0]) or None

    @property
    def t(self) -> float:
        """Time of the estimate (s)."""
        return float(self._dt_t[1])

    @t.setter
    def t(self, value: float) -> None:
        self._dt_t[1] = float(value)

    # ------------------------------------------------------------------ the stepper
    def predict(self, t: float, dt: float, u=None) -> None:
        """Advance from ``t`` to ``t + dt`` (the known inputs are the model's own schedule; ``u`` is unused).

        A plant copy that cannot take the step is a divergence (re-initialised, tried again); a second
        failure raises a :class:`~postcapture.core.errors.SimulationError` (the engine's, or the model's
        :class:`~postcapture.core.errors.DomainError` for parameters it refuses).
        """
        try:
            if self._outside:
                self._predict_outside(float(t), float(dt))
            else:
                self._eng.aug_predict(self._handle, float(t), float(dt))
        finally:
            self._sync()

    def _step_outside(self, t: float, dt: float):
        """The model's step from the filter's state with the engine's ``p(eta)``: ``x1``, ``F``, ``G`` (contiguous)."""
        model, h = self.model, self._handle
        p = np.zeros(self.params.p_nominal.size)
        self._eng.aug_plant_params(h, p, None)
        model.set_params(p)
        pred = model.predict(self._x.copy(), t, dt, jacobians=True)
        if pred.G is None:
            raise SimulationError(f"{self.name}: {model.name} gave no parameter Jacobian G = d x1 / d p")
        return tuple(np.ascontiguousarray(a, dtype=float) for a in (pred.x, pred.F, pred.G))

    def _predict_outside(self, t: float, dt: float) -> None:
        """:meth:`predict` over a model that steps outside the engine: the engine's failure model (a failed step
        diverges and re-initialises, the step is tried again with the prior's parameters, a second failure
        raises), then the engine's propagation with the given step."""
        try:
            x1, F, G = self._step_outside(t, dt)
        except _PLANT_FAILURES as exc:
            text = f"{type(exc).__name__}: {exc}".encode(errors="replace")[: _engine.EVENT_TEXT - 1]
            status = getattr(exc, "status", 0)
            self._eng.aug_plant_failed(self._handle, t, status if isinstance(status, int) else 0, text)
            try:
                x1, F, G = self._step_outside(t, dt)
            except (SimulationError, DomainError):
                raise
            except FMIError as again:  # what the schemes take for a plant copy that failed again
                raise SimulationError(f"{self.name}: the plant copy failed again: {again}") from again
        n, n_p = self.n, self.params.p_nominal.size
        if x1.shape != (self._x.size,) or F.shape != (n, n) or G.shape != (n, n_p):
            raise SimulationError(f"{self.name}: the model's step: expected x ({self._x.size},), F ({n}, {n}) and "
                                  f"G ({n}, {n_p}), found {x1.shape}, {F.shape} and {G.shape}")
        self._eng.aug_predict_given(self._handle, t, dt, x1, F, G)

    def update(self, z: Measurement):
        """Correct with a star-tracker, gyro, accelerometer or encoder measurement; returns the update result or None.

        NaN entries of an accelerometer or encoder sample are missing and left out; a star-tracker or gyro
        sample with any NaN is missing.
        """
        kind = self._KIND.get(z.kind)
        if kind is None:
            raise ValueError("measurement kind: expected star_tracker, gyro, accelerometer or encoders, "
                             f"found {z.kind!r}")
        value, R = np.asarray(z.value, dtype=float), np.asarray(z.R, dtype=float)
        in_value, in_R = self._in_views[kind]
        if value.shape != in_value.shape or R.shape != in_R.shape:
            raise ValueError(f"{z.kind}: expected a value of {in_value.size} components and its covariance, found "
                             f"shapes {value.shape} and {R.shape}")
        in_value[...], in_R[...] = value, R
        addr = self._addr
        self._update_call(self._handle, kind, float(z.t), addr["value"], addr["R"], addr["res"])
        return self._result(z.kind, z.t)

    # ------------------------------------------------------------------ faults
    def reopen_bias(self, sensor: str, axis: int, sigma: float) -> None:
        """Let a bias (the gyro's or the accelerometer's, on one axis) step now by ``sigma`` (1-sigma)."""
        index = (self.i_bg if sensor == "gyro" else self.i_ba).start + axis
        self._eng.aug_reopen(self._handle, index, float(sigma))

    # ------------------------------------------------------------------ outputs
    @property
    def q_BN(self) -> np.ndarray:
        """Attitude estimate (scalar first)."""
        return self.model.attitude(self._x)

    def parameters(self) -> np.ndarray:
        """The estimated parameter vector of the plant (its ``param_names``)."""
        p = np.zeros(self.params.p_nominal.size)
        self._eng.aug_parameters(self._handle, p, None)
        return p

    def parameter_covariance(self) -> np.ndarray:
        """Covariance of the plant's parameter vector, first order through ``dp / d eta``."""
        return self.parameters_with_covariance()[1]

    def parameters_with_covariance(self) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`parameters` and :meth:`parameter_covariance` from one engine call (the engine computes the
        parameters the same way with or without their covariance)."""
        p, C = np.zeros(self.params.p_nominal.size), np.zeros_like(self._C_buf)
        self._eng.aug_parameters(self._handle, p, C)
        return p, C
