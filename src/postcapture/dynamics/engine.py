"""The ctypes boundary of the compiled plant core: every C function declared once, with typed arguments.

Array arguments are ``numpy.ctypeslib.ndpointer`` types (float64 or int32, C-contiguous), so ctypes
itself refuses a list, a wrong dtype or a strided view; optional ones accept None (a NULL pointer).
Every status-returning function is wrapped once (as FMPy wraps its FMI calls): a non-zero status raises
the :class:`EngineError` subclass of that status, carrying the status, the function and the data's
error text. No caller checks a return code by hand.

:class:`EngineModel` is the constant model (``pc_model_t``): created from the packed arrays and a
tableau, validated by the core (``pc_validate``; a refusal raises :class:`ModelError` with the core's
reason), never changed, shared by any number of instances (:class:`~postcapture.dynamics.core.CompiledPlant`),
each with its own data.
"""

from __future__ import annotations

import ctypes
import threading

import numpy as np

from postcapture.core.errors import DomainError, SimulationError
from postcapture.dynamics.compiled import load_library

__all__ = ["EngineError", "NewtonError", "NonFiniteStateError", "SingularMatrixError", "EngineArgumentError",
           "ArenaError", "ModelError", "Engine", "engine", "EngineModel", "layout_version", "UpdateStruct",
           "PolicyStruct", "AugConfigStruct", "MAX_MEAS", "EVENT_TEXT", "EVENT_DOUBLES"]


class EngineError(SimulationError):
    """A call of the compiled core failed. ``status`` is the core's code, ``function`` the C function."""

    def __init__(self, message: str, status: int = 0, function: str = ""):
        self.status = status
        self.function = function
        super().__init__(message)


class NewtonError(EngineError):
    """An implicit stage did not converge (status 1): the step is too large or the state is not finite."""


class NonFiniteStateError(EngineError):
    """A step produced a non-finite state (status 2)."""


class SingularMatrixError(EngineError):
    """A mass, Newton or sensitivity matrix is singular (status 3)."""


class EngineArgumentError(EngineError, DomainError):
    """An argument was refused (status 4): a non-finite state, an unphysical parameter vector, ..."""


class ArenaError(EngineError):
    """The instance's scratch arena was too small (status 5): a bug in its sizing, never a lack of memory."""


class ModelError(EngineError, ValueError):
    """The packed model or the tableau was refused by ``pc_validate`` (status 6)."""


_ERRORS = {1: NewtonError, 2: NonFiniteStateError, 3: SingularMatrixError, 4: EngineArgumentError, 5: ArenaError,
           6: ModelError}


def _optional(base):
    """An ndpointer type that also accepts None (NULL)."""

    class Optional(base):
        @classmethod
        def from_param(cls, obj):
            return None if obj is None else base.from_param(obj)

    return Optional


_D = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
_OD = _optional(_D)
_I = np.ctypeslib.ndpointer(dtype=np.int32, flags="C_CONTIGUOUS")
_OI = _optional(_I)
_L = np.ctypeslib.ndpointer(dtype=np.int64, flags="C_CONTIGUOUS")
_H, _INT, _DBL, _SZ = ctypes.c_void_p, ctypes.c_int, ctypes.c_double, ctypes.c_size_t

# name: (argument types, index of the data handle whose error text explains a failure, or None)
_STATUS_CALLS = {
    "pc_sizes": ([_H, _I], None),
    "pc_nominal_params": ([_H, _D], None),
    "pc_data_copy": ([_H, _H, _H], 1),
    "pc_set_params": ([_H, _H, _D], 1),
    "pc_get_params": ([_H, _H, _D], 1),
    "pc_set_input_offset": ([_H, _H, _OD], 1),
    "pc_set_orbit": ([_H, _H, _DBL], 1),
    "pc_set_newton": ([_H, _DBL, _DBL, _INT], 0),
    "pc_inputs": ([_H, _H, _DBL, _INT, _D], 1),
    "pc_inputs_eval": ([_INT, _OI, _OD, _INT, _OD, _OD, _INT, _INT, _D, _INT, _D], None),
    "pc_aba": ([_H, _H, _D, _D, _D, _D], 1),
    "pc_rnea": ([_H, _H, _D, _D, _D, _D], 1),
    "pc_rnea_derivatives": ([_H, _H, _D, _D, _D, _OD, _OD], 1),
    "pc_accel": ([_H, _H, _D, _D, _D, _D], 1),
    "pc_derivatives": ([_H, _H, _D, _D, _D, _OD, _OD, _OD, _OD, _OD], 1),
    "pc_mass_matrix": ([_H, _H, _D, _D], 1),
    "pc_center_of_mass": ([_H, _H, _D, _D], 1),
    "pc_integrate": ([_H, _D, _D, _D], None),
    "pc_difference": ([_H, _D, _D, _D], None),
    "pc_lie_integrate": ([_INT, _INT, _INT, _D, _D, _D], None),
    "pc_lie_difference": ([_INT, _INT, _INT, _D, _D, _D], None),
    "pc_measure": ([_H, _H, _D, _D, _DBL, _D, _OD, _OD, _OD], 1),
    "pc_sample": ([_H, _H, _D, _D, _DBL, _D, _OD, _OD], 1),
    "pc_panel_outputs": ([_H, _H, _D, _D], 1),
    "pc_panel_jacobian": ([_H, _H, _D, _D], 1),
    "pc_panel_quat_jacobian": ([_H, _H, _D, _D], 1),
    "pc_step": ([_H, _H, _D, _D, _DBL, _DBL, _OD], 1),
    "pc_step_jacobian": ([_H, _H, _D, _D, _DBL, _DBL, _OD, _OD, _OD], 1),
    "pc_simulate": ([_H, _H, _D, _D, _DBL, _DBL, _DBL, _INT, _INT, _INT, _D, _D, _D, _D, _D, _D, _D,
                     ctypes.POINTER(ctypes.c_int)], 1),
    "pc_predict": ([_H, _H, _D, _D, _DBL, _DBL, _INT, _INT, _D, _OD, _OD, _OD, _OD, _OD, _OD], 1),
}


# ------------------------------------------------------------------ the filters (pc_filter.h)
MAX_MEAS, EVENT_TEXT, EVENT_DOUBLES = 32, 200, 12


class UpdateStruct(ctypes.Structure):
    """``pc_update_t``: one update's outcome."""

    _fields_ = [("m", ctypes.c_int), ("accepted", ctypes.c_int), ("missing", ctypes.c_int), ("nis", ctypes.c_double),
                ("threshold", ctypes.c_double), ("innovation", ctypes.c_double * MAX_MEAS),
                ("S", ctypes.c_double * (MAX_MEAS * MAX_MEAS))]


class PolicyStruct(ctypes.Structure):
    """``pc_policy_t``: recovery policy and gate tables (the arrays must outlive the filter's creation)."""

    _fields_ = [("reject_limit", ctypes.c_int), ("nis_window", ctypes.c_int), ("max_recoveries", ctypes.c_int),
                ("gated", ctypes.c_int), ("n_gate", ctypes.c_int), ("n_window_bound", ctypes.c_int),
                ("inflation", ctypes.c_double), ("gyro_bias_bump", ctypes.c_double),
                ("recovery_window", ctypes.c_double), ("gate", ctypes.POINTER(ctypes.c_double)),
                ("window_bound", ctypes.POINTER(ctypes.c_double))]


class AugConfigStruct(ctypes.Structure):
    """``pc_aug_config_t``: the augmented EKF's layout and noise (the arrays must outlive its creation)."""

    _fields_ = [("n_arm", ctypes.c_int), ("n_cal", ctypes.c_int), ("n_consider", ctypes.c_int),
                ("full_noise", ctypes.c_int), ("n_spec", ctypes.c_int), ("arm_v", ctypes.POINTER(ctypes.c_int)),
                ("param_spec", ctypes.POINTER(ctypes.c_int)), ("p_nominal", ctypes.POINTER(ctypes.c_double)),
                ("step", ctypes.c_double), ("r_accel", ctypes.c_double * 3), ("sigma_gyro_walk", ctypes.c_double),
                ("sigma_accel_walk", ctypes.c_double), ("mean_motion", ctypes.c_double),
                ("frozen_jacobian", ctypes.c_int)]


_U = ctypes.POINTER(UpdateStruct)
_POL = ctypes.POINTER(PolicyStruct)
_B = np.ctypeslib.ndpointer(dtype=np.uint8, flags="C_CONTIGUOUS")
_OB = _optional(_B)

# filter calls whose failure the filter's own message explains (argument 0 is the filter)
_FILTER_CALLS = {
    "pc_mekf_predict": [_H, _DBL, _DBL, _D],
    "pc_mekf_update": [_H, _DBL, _D, _D, _U],
    "pc_atekf_predict": [_H, _DBL, _D, _OD],
    "pc_atekf_update": [_H, _DBL, _D, _D, _D, _D, _D, _U],
    "pc_massf_predict": [_H, _DBL],
    "pc_massf_update": [_H, _DBL, _INT, _D, _D, _D, _U],
    "pc_aug_predict": [_H, _DBL, _DBL],
    "pc_aug_update": [_H, _INT, _DBL, _D, _D, _U],
    "pc_aug_sizes": [_H, _I],
    "pc_aug_measure": [_H, _INT, _D, _D],
    "pc_aug_parameters": [_H, _D, _OD],
    "pc_aug_plant_params": [_H, _OD, _OD],
    "pc_aug_predict_given": [_H, _DBL, _DBL, _D, _D, _D],
}
# calls that return nothing or a value
_FILTER_PLAIN = {
    "pc_mekf_create": (_H, [_INT, _D, _OD, _D, _DBL, _DBL, _DBL, _DBL, _DBL, _POL]),
    "pc_atekf_create": (_H, [_D, _D, _DBL, _POL]),
    "pc_massf_create": (_H, [_INT, _DBL, _DBL, _DBL, _DBL, _DBL, _DBL, _DBL, _DBL, _DBL, _DBL, _DBL, _POL]),
    "pc_aug_create": (_H, [_H, _H, ctypes.POINTER(AugConfigStruct), _D, _D, _D, _D, _POL, ctypes.c_char_p, _SZ]),
    "pc_filter_status": (_INT, [_H, _L]),
    "pc_filter_events": (_INT, [_H, _D, ctypes.c_char_p, _INT]),
    "pc_filter_message": (ctypes.c_char_p, [_H]),
    "pc_filter_state": (ctypes.POINTER(ctypes.c_double), [_H, ctypes.POINTER(_SZ)]),
    "pc_filter_destroy": (None, [_H]),
    "pc_aug_create_external": (_H, [_INT, _INT, _INT, ctypes.POINTER(AugConfigStruct), _D, _D, _D, _D, _POL,
                                    ctypes.c_char_p, _SZ]),
    "pc_aug_plant_failed": (None, [_H, _DBL, _INT, ctypes.c_char_p]),
    "pc_aug_reopen": (None, [_H, _INT, _DBL]),
    "pc_aug_apply": (None, [_H, _D]),
    "pc_mekf_transition": (None, [_D, _DBL, _D]),
    "pc_mekf_noise": (None, [_DBL, _DBL, _DBL, _D]),
    "pc_kf_workspace": (_SZ, [_INT, _INT]),
    "pc_massf_noise": (_DBL, [_H, _DBL]),
    "pc_kf_predict": (None, [_INT, _D, _D, _D, _D]),
    "pc_kf_update": (_INT, [_INT, _INT, _D, _D, _D, _D, _OB, _DBL, _OD, _OD, _U, _D]),
    "pc_mean_rate": (None, [_D, _D, _DBL, _D, _OD, _OD, _OD]),
    "pc_mean_specific_force": (None, [_D, _D, _D, _D, _D, _D, _DBL, _D, _OD]),
    "pc_triad_matrix": (None, [_D, _D]),
    "pc_tidal_mean": (None, [_D, _D, _D, _D, _D, _DBL, _DBL, _DBL, _D]),
    "pc_triad_sensitivity": (None, [_D, _D]),
    "pc_log_cholesky": (None, [_D, _OD, _OD]),
    "pc_parammap_size": (_INT, [_I, _INT, _INT]),
    "pc_parammap_apply": (None, [_I, _D, _INT, _D, _OD, _OD]),
    "pc_sigmoid": (None, [_DBL, _DBL, _DBL, _DBL, ctypes.POINTER(_DBL), ctypes.POINTER(_DBL)]),
    "pc_massf_estimate": (None, [_H, ctypes.POINTER(_DBL), ctypes.POINTER(_DBL)]),
    "pc_rdual_propagate": (None, [_INT, _D, _D, _D, _D]),
    "pc_rdual_lean": (None, [_D, _D]),
    "pc_rdual_mass_noise": (None, [_D, _DBL, _DBL, _D]),
    "pc_rdual_devices": (None, [_D, _D, _D, _D, _D, _D, _D, _DBL, _D, _D, _INT, _D, _D, _D, _D]),
    "pc_dmass_direction": (None, [_D, _D]),
    "pc_target_mass": (_INT, [_D, _DBL, _D]),
}


class _StatusCall:
    """One status-returning core function: declared once; a non-zero status raises its error type."""

    __slots__ = ("_fn", "_name", "_data", "_message")

    def __init__(self, lib: ctypes.CDLL, name: str, argtypes: list, data_arg: int | None, message):
        fn = getattr(lib, name)
        fn.restype = ctypes.c_int
        fn.argtypes = argtypes
        self._fn, self._name, self._data, self._message = fn, name, data_arg, message

    def __call__(self, *args) -> None:
        status = self._fn(*args)
        if status:
            text = self._message(args[self._data]) if self._data is not None else "arguments refused"
            raise _ERRORS.get(status, EngineError)(f"{self._name}: {text}", status=status, function=self._name)


class _AddressCall(_StatusCall):
    """A status-returning filter call declared over an address-taking function object (:meth:`Engine.by_address`)."""

    __slots__ = ()

    def __init__(self, fn, name: str, message):
        self._fn, self._name, self._data, self._message = fn, name, 0, message


_SCALARS = (_H, _INT, _DBL, _SZ)


class Engine:
    """The loaded core with every function declared; attribute ``x`` is the C function ``pc_x``."""

    def __init__(self, lib: ctypes.CDLL):
        self.lib = lib
        self._address_calls: dict = {}
        for name, restype, argtypes in (
            ("pc_model_create", _H, [_I, _D, _SZ, _SZ, _INT, _D, _D, _D, ctypes.c_char_p, _SZ]),
            ("pc_model_destroy", None, [_H]),
            ("pc_data_create", _H, [_H]),
            ("pc_data_destroy", None, [_H]),
            ("pc_error_message", ctypes.c_char_p, [_H]),
            ("pc_stats", None, [_H, _L]),
            ("pc_reset_stats", None, [_H]),
            ("pc_layout_version", ctypes.c_int, []),
        ):
            fn = getattr(lib, name)
            fn.restype, fn.argtypes = restype, argtypes
            setattr(self, name[3:], fn)
        for name, (argtypes, data_arg) in _STATUS_CALLS.items():
            setattr(self, name[3:], _StatusCall(lib, name, argtypes, data_arg, self.message))
        for name, (restype, argtypes) in _FILTER_PLAIN.items():
            fn = getattr(lib, name)
            fn.restype, fn.argtypes = restype, argtypes
            setattr(self, name[3:], fn)
        for name, argtypes in _FILTER_CALLS.items():
            setattr(self, name[3:], _StatusCall(lib, name, argtypes, 0, self.filter_message))

    def by_address(self, name: str):
        """The filter function ``pc_<name>`` declared a second time, each array, buffer or struct argument an
        address (an int, ``c_void_p``): for the calls a filter makes every cycle over buffers it allocated once
        and never replaces, whose addresses it takes once (numpy's ndpointer check and conversion cost a few
        microseconds an argument, tens of thousands of times a run). The attribute ``name`` keeps its checked
        declaration; a status-returning call raises as that one does."""
        full = f"pc_{name}"
        if full in self._address_calls:
            return self._address_calls[full]
        status = full in _FILTER_CALLS
        restype, argtypes = (ctypes.c_int, _FILTER_CALLS[full]) if status else _FILTER_PLAIN[full]
        fn = self.lib[full]  # a new function object: the library's own (the checked declaration) is left as it is
        fn.restype, fn.argtypes = restype, [a if a in _SCALARS else ctypes.c_void_p for a in argtypes]
        call = self._address_calls[full] = _AddressCall(fn, full, self.filter_message) if status else fn
        return call

    def message(self, data) -> str:
        """The error text a data holds (its last failure)."""
        return self.error_message(data).decode(errors="replace") if data else ""

    def filter_message(self, f) -> str:
        """The error text a filter holds (its last failure)."""
        return self.lib.pc_filter_message(f).decode(errors="replace") if f else ""


_ENGINE: Engine | None = None
_LOCK = threading.Lock()


def engine() -> Engine:
    """The compiled core, built and verified on first use (:func:`postcapture.dynamics.compiled.load_library`)."""
    global _ENGINE
    with _LOCK:
        if _ENGINE is None:
            _ENGINE = Engine(load_library())
        return _ENGINE


def layout_version() -> int:
    """The packed layout version the core reads (the one place it is written is ``csrc/pc_plant.h``)."""
    return int(engine().layout_version())


class EngineModel:
    """The constant model in the core: a validated ``pc_model_t`` shared by every instance built over it.

    Parameters
    ----------
    ints, doubles : ndarray
        The packed model (:func:`postcapture.dynamics.packing.pack`).
    tableau : Tableau
        The integrator's Butcher tableau (lower-triangular ``A``).
    param_names : tuple of str
        Names of the parameter vector.

    Raises
    ------
    ModelError
        With the core's reason (``pc_validate``: the first index, size or number out of range).
    """

    def __init__(self, ints: np.ndarray, doubles: np.ndarray, tableau, param_names: tuple[str, ...] = ()):
        self.engine = eng = engine()
        ints = np.ascontiguousarray(ints, dtype=np.int32)
        doubles = np.ascontiguousarray(doubles, dtype=np.float64)
        self.ints, self.doubles, self.param_names = ints, doubles, tuple(param_names)
        A = np.ascontiguousarray(tableau.A, dtype=np.float64)
        b = np.ascontiguousarray(tableau.b, dtype=np.float64)
        c = np.ascontiguousarray(tableau.c, dtype=np.float64)
        s = int(tableau.stages)
        if A.shape != (s, s) or b.shape != (s,) or c.shape != (s,):
            raise ModelError(f"tableau: expected A ({s}, {s}), b and c ({s},), found {A.shape}, {b.shape}, {c.shape}",
                             status=6, function="pc_model_create")
        err = ctypes.create_string_buffer(512)
        handle = eng.model_create(ints, doubles, ints.size, doubles.size, s, A, b, c, err, len(err))
        if not handle:
            raise ModelError(f"the compiled core refused the model: {err.value.decode(errors='replace')}", status=6,
                             function="pc_model_create")
        self.handle = handle
        self.tableau = tableau
        sizes = np.zeros(8, dtype=np.int32)
        eng.sizes(handle, sizes)
        self.nq, self.nv, self.nu, self.np, self.nz, self.npanels, self.nj, _ = (int(x) for x in sizes)
        self.nt = 2 * self.nv

    def __reduce__(self):  # another process builds its own from the same arrays (a handle means nothing there)
        return (EngineModel, (self.ints, self.doubles, self.tableau, self.param_names))

    def nominal_params(self) -> np.ndarray:
        """The parameter vector the model was packed with."""
        p = np.zeros(self.np)
        self.engine.nominal_params(self.handle, p)
        return p

    def __del__(self):
        handle, eng = getattr(self, "handle", None), getattr(self, "engine", None)
        if handle and eng is not None:
            eng.model_destroy(handle)
            self.handle = None
