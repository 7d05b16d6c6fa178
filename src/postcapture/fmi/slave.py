"""A co-simulation FMU instance driven through raw FMI calls on preallocated buffers.

FMPy's high-level methods (``getReal``, ``setReal``, ...) build ctypes arrays from Python lists on every
call (about 17 us for 100 variables); here the value references and values live in numpy arrays whose
pointers are made once, and the C functions FMPy loaded are called directly (under 1 us per call).
A status above Warning becomes :class:`~postcapture.core.errors.FMIError` naming the FMU, the function
and the status. FMI 2.0 and 3.0 co-simulation FMUs are supported.
"""

from __future__ import annotations

import logging
from ctypes import POINTER, byref, c_bool, c_double, c_uint, c_void_p

import numpy as np

from postcapture.core.errors import FMIError
from postcapture.fmi._extras import import_fmpy

__all__ = ["STATUS_NAMES", "Buffer", "RawSlave"]

logger = logging.getLogger(__name__)

STATUS_NAMES = {0: "OK", 1: "Warning", 2: "Discard", 3: "Error", 4: "Fatal", 5: "Pending"}


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
            self.fmu.instantiate()
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

    # ------------------------------------------------------------------ checks
    def _check(self, status: int, function: str) -> None:
        if status > 1:
            raise FMIError(
                "the call failed (see the FMU's log for its message)",
                fmu=self.label,
                function=f"{self._prefix}{function}",
                status=STATUS_NAMES.get(status, str(status)),
            )

    # ------------------------------------------------------------------ values
    def set_real(self, buf: Buffer) -> None:
        """Set the variables of ``buf`` to ``buf.values``."""
        if self.version == 3:
            st = self._set(self._c, buf.vr_ptr, buf.n, buf.val_ptr, buf.n)
        else:
            st = self._set(self._c, buf.vr_ptr, buf.n, buf.val_ptr)
        self._check(st, "SetFloat64" if self.version == 3 else "SetReal")

    def get_real(self, buf: Buffer) -> np.ndarray:
        """Read the variables of ``buf`` into ``buf.values`` (returned, not copied)."""
        if self.version == 3:
            st = self._get(self._c, buf.vr_ptr, buf.n, buf.val_ptr, buf.n)
        else:
            st = self._get(self._c, buf.vr_ptr, buf.n, buf.val_ptr)
        self._check(st, "GetFloat64" if self.version == 3 else "GetReal")
        return buf.values

    def do_step(self, t: float, h: float) -> None:
        """One communication step from ``t`` (s) of length ``h`` (s)."""
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
        for call in (fmu.terminate, fmu.freeInstance, fmu.freeLibrary):
            try:
                call()
            except Exception as exc:  # closing must not raise: the instance may be in error
                logger.debug("%s: %s during close: %s", self.label, call.__name__, exc)
