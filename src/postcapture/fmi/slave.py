"""A co-simulation FMU instance driven through raw FMI calls on preallocated buffers.

FMPy's high-level methods (``getReal``, ``setReal``, ...) build ctypes arrays from Python lists on every
call (about 17 us for 100 variables); here the value references and values live in numpy arrays whose
pointers are made once, and the C functions FMPy loaded are called directly (under 1 us per call).
A status above Warning becomes :class:`~postcapture.core.errors.FMIError` naming the FMU, the function
and the status, with the FMU's own last log messages. FMI 2.0 and 3.0 co-simulation FMUs are supported.

The FMU's log messages go to Python logging (logger ``postcapture.fmi.slave``), never to stdout. After
a call returns Error or Fatal the instance is in the FMI error state: every later call but closing
raises at once, naming the call that failed, instead of reaching the FMU.
"""

from __future__ import annotations

import itertools
import logging
import weakref
from collections import deque
from ctypes import POINTER, byref, c_bool, c_double, c_uint, c_void_p

import numpy as np

from postcapture.core.errors import FMIError
from postcapture.fmi._extras import import_fmpy

__all__ = ["STATUS_NAMES", "Buffer", "RawSlave"]

logger = logging.getLogger(__name__)

STATUS_NAMES = {0: "OK", 1: "Warning", 2: "Discard", 3: "Error", 4: "Fatal", 5: "Pending"}
_LOG_LEVELS = {0: logging.DEBUG, 1: logging.WARNING, 2: logging.INFO, 3: logging.INFO, 4: logging.INFO}
# Discard, Error and Fatal messages are logged quietly: they are repeated in the FMIError raised.


def _text(value) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8", errors="replace")
    return "" if value is None else str(value)


_SLAVES: dict[int, weakref.ref] = {}
_PROXY: list = []  # the one FMI 2.0 callback structure FMPy's logger proxy holds on to (never freed)
_TOKENS = itertools.count(1)


def _dispatch(env, name, status, category, message) -> None:
    """The process-wide FMI 2.0 logger: to the RawSlave named by the environment, else FMPy's default."""
    ref = _SLAVES.get(env or 0)
    slave = ref() if ref is not None else None
    if slave is not None:
        slave._log(status, category, message)
        return
    try:
        from fmpy.fmi1 import printLogMessage

        printLogMessage(env, name, status, category, message)  # what FMPy does for its own instances
    except Exception:  # noqa: BLE001 - an exception must never cross the C callback
        pass


def _fmi2_callbacks(slave):
    """FMI 2.0 callbacks whose log messages reach ``slave._log``, formatted.

    FMPy's C proxy formats the variadic message, then calls one process-wide Python logger (it keeps a
    single global pointer): that logger is :func:`_dispatch`, installed once and never freed, and each
    instance gets its own environment token to be found again.
    """
    from fmpy import fmi2
    from fmpy.logging import addLoggerProxy

    if not _PROXY:
        base = fmi2.fmi2CallbackFunctions()
        base.logger = fmi2.fmi2CallbackLoggerTYPE(_dispatch)
        base.allocateMemory = fmi2.fmi2CallbackAllocateMemoryTYPE(fmi2.calloc)
        base.freeMemory = fmi2.fmi2CallbackFreeMemoryTYPE(fmi2.free)
        addLoggerProxy(byref(base))  # now base.logger is the C proxy
        _PROXY.append(base)
    base = _PROXY[0]
    token = next(_TOKENS)
    _SLAVES[token] = weakref.ref(slave, lambda _ref, token=token: _SLAVES.pop(token, None))
    cb = fmi2.fmi2CallbackFunctions()
    cb.logger, cb.allocateMemory, cb.freeMemory = base.logger, base.allocateMemory, base.freeMemory
    cb.componentEnvironment = token
    return cb


class Buffer:
    """Value references and a value array with their ctypes pointers, made once.

    Parameters
    ----------
    vrs : sequence of int
        Value references.
    """

    def __init__(self, vrs):
        self.vr = np.ascontiguousarray(vrs, dtype=np.uint32)
        self.values = np.zeros(self.vr.size)
        self.n = int(self.vr.size)
        self.vr_ptr = self.vr.ctypes.data_as(POINTER(c_uint))
        self.val_ptr = self.values.ctypes.data_as(POINTER(c_double))


class RawSlave:
    """One instantiated and initialised co-simulation FMU (FMI 2.0 or 3.0).

    Parameters
    ----------
    model_description : fmpy.model_description.ModelDescription
    unzip_dir : str
        Directory of the extracted FMU.
    label : str
        The FMU's name in error messages (usually its path).
    instance_name : str
    start_time : float
        Start time (s).
    """

    def __init__(
        self,
        model_description,
        unzip_dir: str,
        label: str,
        instance_name: str = "postcapture",
        start_time: float = 0.0,
    ):
        import_fmpy()
        from fmpy.fmi2 import FMU2Slave
        from fmpy.fmi3 import FMU3Slave

        md = model_description
        self.label = label
        self.version = 3 if md.fmiVersion.startswith("3") else 2
        self.failed: str | None = None  # the call that put the FMU in the error state
        self.messages: deque = deque(maxlen=5)  # the FMU's last warning and error messages
        cls = FMU3Slave if self.version == 3 else FMU2Slave
        try:
            self.fmu = cls(
                guid=md.guid,
                unzipDirectory=unzip_dir,
                modelIdentifier=md.coSimulation.modelIdentifier,
                instanceName=instance_name,
            )
        except Exception as exc:  # FMPy raises plain Exception for a missing or unloadable library
            raise FMIError(f"cannot load the shared library: {exc}", fmu=label, function="load") from exc
        self._prefix = "fmi3" if self.version == 3 else "fmi2"
        try:
            self._instantiate()
        except Exception as exc:
            raise FMIError(
                f"instantiation failed: {exc}", fmu=label, function=f"{self._prefix}Instantiate"
            ) from exc
        try:
            if self.version == 3:
                self.fmu.enterInitializationMode(startTime=start_time)
            else:
                self.fmu.setupExperiment(startTime=start_time)
                self.fmu.enterInitializationMode()
            self.fmu.exitInitializationMode()
        except Exception as exc:
            status = STATUS_NAMES.get(getattr(exc, "status", None))
            raise FMIError(
                f"initialisation failed: {exc}",
                fmu=label,
                function=getattr(exc, "function", "initialize"),
                status=status,
            ) from exc
        f = self.fmu._functions
        self._c = self.fmu.component
        name = "Float64" if self.version == 3 else "Real"
        self._set = f[f"{self._prefix}Set{name}"]
        self._get = f[f"{self._prefix}Get{name}"]
        self._step = f[f"{self._prefix}DoStep"]
        self._dd = f.get(f"{self._prefix}GetDirectionalDerivative")
        state = "FMUState" if self.version == 3 else "FMUstate"
        self._get_state = f.get(f"{self._prefix}Get{state}")
        self._set_state = f.get(f"{self._prefix}Set{state}")
        self._free_state = f.get(f"{self._prefix}Free{state}")
        if self.version == 3:
            self._event, self._term, self._early = c_bool(), c_bool(), c_bool()
            self._last = c_double()

    # ------------------------------------------------------------------ logging
    def _log(self, status, category, message) -> None:
        """The FMU's log callback: to Python logging, and the last warnings kept for error messages."""
        try:
            status = int(status)
            text = _text(message).strip()
            logger.log(_LOG_LEVELS.get(status, logging.INFO), "%s [%s] %s", self.label,
                       STATUS_NAMES.get(status, status), text)
            if status >= 1 and text:
                self.messages.append(text)
        except Exception:  # noqa: BLE001 - an exception must never cross the C callback
            pass

    def _instantiate(self) -> None:
        if self.version == 3:
            self.fmu.instantiate(logMessage=lambda env, status, category, message: self._log(status, category, message))
            return
        self._callbacks = _fmi2_callbacks(self)  # kept alive as long as the instance
        self.fmu.instantiate(callbacks=self._callbacks)

    # ------------------------------------------------------------------ checks
    def _check(self, status: int, function: str) -> None:
        if status > 1:
            name = f"{self._prefix}{function}"
            said = "; the FMU said: " + " | ".join(self.messages) if self.messages else \
                " (the FMU logged no message)"
            self.messages.clear()
            if status in (3, 4):
                self.failed = f"{name} returned {STATUS_NAMES[status]}"
            raise FMIError(
                f"the call failed{said}",
                fmu=self.label,
                function=name,
                status=STATUS_NAMES.get(status, str(status)),
            )

    def _usable(self, function: str) -> None:
        """Refuse a call on an instance in the error state (FMI: only freeing it is allowed then)."""
        if self.failed is not None:
            raise FMIError(
                f"the FMU is in the error state since {self.failed}; it can only be freed",
                fmu=self.label,
                function=f"{self._prefix}{function}",
            )

    # ------------------------------------------------------------------ values
    def set_real(self, buf: Buffer) -> None:
        """Set the variables of ``buf`` to ``buf.values``."""
        self._usable("SetFloat64" if self.version == 3 else "SetReal")
        if self.version == 3:
            st = self._set(self._c, buf.vr_ptr, buf.n, buf.val_ptr, buf.n)
        else:
            st = self._set(self._c, buf.vr_ptr, buf.n, buf.val_ptr)
        self._check(st, "SetFloat64" if self.version == 3 else "SetReal")

    def get_real(self, buf: Buffer) -> np.ndarray:
        """Read the variables of ``buf`` into ``buf.values`` (returned, not copied; allowed in the error state)."""
        if self.version == 3:
            st = self._get(self._c, buf.vr_ptr, buf.n, buf.val_ptr, buf.n)
        else:
            st = self._get(self._c, buf.vr_ptr, buf.n, buf.val_ptr)
        self._check(st, "GetFloat64" if self.version == 3 else "GetReal")
        return buf.values

    def do_step(self, t: float, h: float) -> None:
        """One communication step from ``t`` (s) of length ``h`` (s)."""
        self._usable("DoStep")
        if self.version == 3:
            st = self._step(
                self._c,
                t,
                h,
                True,
                byref(self._event),
                byref(self._term),
                byref(self._early),
                byref(self._last),
            )
        else:
            st = self._step(self._c, t, h, 1)
        self._check(st, "DoStep")

    def directional(self, unknown: Buffer, known: Buffer, seed: np.ndarray, out: np.ndarray) -> np.ndarray:
        """``out = J seed`` with ``J = d unknown / d known`` (continuous partials at the current time)."""
        self._usable("GetDirectionalDerivative")
        if self._dd is None:
            raise FMIError(
                "no directional derivatives in the library",
                fmu=self.label,
                function=f"{self._prefix}GetDirectionalDerivative",
            )
        sp = seed.ctypes.data_as(POINTER(c_double))
        op = out.ctypes.data_as(POINTER(c_double))
        if self.version == 3:
            st = self._dd(
                self._c, unknown.vr_ptr, unknown.n, known.vr_ptr, known.n, sp, known.n, op, unknown.n
            )
        else:
            st = self._dd(self._c, unknown.vr_ptr, unknown.n, known.vr_ptr, known.n, sp, op)
        self._check(st, "GetDirectionalDerivative")
        return out

    # ------------------------------------------------------------------ FMU state
    def get_state(self, handle: c_void_p | None = None) -> c_void_p:
        """Save the FMU state (into ``handle`` when given, reusing its memory)."""
        self._usable("GetFMUState" if self.version == 3 else "GetFMUstate")
        if self._get_state is None:
            raise FMIError(
                "the library has no FMU-state functions",
                fmu=self.label,
                function=f"{self._prefix}GetFMUstate",
            )
        handle = handle if handle is not None else c_void_p()
        self._check(
            self._get_state(self._c, byref(handle)), "GetFMUState" if self.version == 3 else "GetFMUstate"
        )
        return handle

    def set_state(self, handle: c_void_p) -> None:
        """Restore a saved FMU state."""
        self._usable("SetFMUState" if self.version == 3 else "SetFMUstate")
        self._check(self._set_state(self._c, handle), "SetFMUState" if self.version == 3 else "SetFMUstate")

    def free_state(self, handle: c_void_p) -> None:
        """Free a saved FMU state."""
        if handle is not None and handle.value:
            self._free_state(self._c, byref(handle))

    def close(self) -> None:
        """Terminate, free the instance and unload the library (errors are logged, not raised)."""
        fmu, self.fmu = getattr(self, "fmu", None), None
        if fmu is None:
            return
        calls = (fmu.terminate, fmu.freeInstance, fmu.freeLibrary) if self.failed is None else \
            (fmu.freeInstance, fmu.freeLibrary)  # FMI: an instance in the error state may only be freed
        for call in calls:
            try:
                call()
            except Exception as exc:  # closing must not raise: the instance may be in error
                logger.debug("%s: %s during close: %s", self.label, call.__name__, exc)
