"""Exception types shared by every layer.

They subclass the matching builtin so that ``except ValueError`` keeps working for callers that do
not know postcapture's own types. Every one of them survives pickling unchanged (type, message and
attributes), so an error raised in a worker process reaches the parent as raised.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "PostcaptureError",
    "Problem",
    "ScenarioError",
    "InputError",
    "ResourceLimitError",
    "OutputPathError",
    "WorkerError",
    "DimensionError",
    "DomainError",
    "CovarianceError",
    "TimeGridError",
    "SimulationError",
    "CompileError",
    "FilterDivergenceError",
    "FMIError",
    "MissingExtraError",
    "PanelModelError",
    "NastranError",
]


def _rebuild(cls, args, state):
    """Unpickle a postcapture error without calling its ``__init__`` (whose signature varies)."""
    exc = cls.__new__(cls, *args)
    exc.args = args
    exc.__dict__.update(state)
    return exc


class PostcaptureError(Exception):
    """Base class of every error raised on purpose by postcapture."""

    def __reduce__(self):
        # The default pickles ``self.args`` and calls ``cls(*args)`` on load, which breaks every subclass
        # whose ``__init__`` takes other arguments than its message (a ScenarioError came back with
        # one "problem" per character, a FilterDivergenceError did not come back at all).
        return (_rebuild, (type(self), self.args, dict(self.__dict__)))


@dataclass(frozen=True)
class Problem:
    """One problem found by a validator: where, what was expected, what was found."""

    path: str
    expected: str
    found: str

    def __str__(self) -> str:
        return f"{self.path}: expected {self.expected}, found {self.found}"


class ScenarioError(PostcaptureError, ValueError):
    """A scenario (or another input description) failed validation.

    Parameters
    ----------
    problems : list of Problem
        Every problem found, not only the first one.
    source : str, optional
        The file or name the description came from.
    """

    _what = "invalid scenario"  # the head of the message; subclasses name what they validate

    def _head(self, source: str | None) -> str:
        return f"{self._what} {source!r}" if source else self._what

    def __init__(self, problems: list[Problem], source: str | None = None):
        self.problems = list(problems)
        self.source = source
        head = self._head(source)
        n = len(self.problems)
        lines = [f"{head}: {n} problem{'s' if n != 1 else ''}"]
        lines += [f"  - {p}" for p in self.problems]
        super().__init__("\n".join(lines))


class InputError(ScenarioError):
    """What a command was given (options, paths, files, scenario) failed validation.

    A `ScenarioError` (and so a ``ValueError``) whose message starts with "invalid input": it carries
    every `Problem` found by one validation pass, with the option or field each one concerns.

    Parameters
    ----------
    problems : list of Problem
        Every problem found.
    source : str, optional
        What was validated (a command name, a file).
    """

    _what = "invalid input"

    def _head(self, source: str | None) -> str:
        return f"invalid input to {source}" if source else self._what


class ResourceLimitError(PostcaptureError, ValueError):
    """A run would need more memory or time than allowed; refused before anything is allocated.

    Attributes
    ----------
    limit : str
        The limit's name (``"memory"``, ``"time"``).
    needed, allowed : float
        The estimate and the limit (bytes or seconds).
    """

    def __init__(self, message: str, limit: str = "", needed: float = float("nan"), allowed: float = float("nan")):
        self.limit = limit
        self.needed = needed
        self.allowed = allowed
        super().__init__(message)


class OutputPathError(PostcaptureError, OSError):
    """An output path cannot be written: not a regular file or folder, not writable, or a failed write.

    Constructed like ``OSError(errno, message, filename)``; ``str()`` reads ``filename: message``.
    """

    __reduce__ = OSError.__reduce__  # keeps errno, message and filename (its __init__ is OSError's)

    def __str__(self) -> str:
        if self.strerror is not None:
            return f"{self.filename}: {self.strerror}" if self.filename else self.strerror
        return super().__str__()


class WorkerError(PostcaptureError, RuntimeError):
    """An unexpected error (a bug) inside a worker process, carried back with its traceback text.

    Attributes
    ----------
    job : str
        The job that failed.
    kind : str
        The original exception's type name.
    traceback : str
        The worker's formatted traceback.
    """

    def __init__(self, job: str, kind: str, message: str, traceback: str = ""):
        self.job = job
        self.kind = kind
        self.traceback = traceback
        super().__init__(f"internal error in worker job {job!r}: {kind}: {message}")


class DimensionError(PostcaptureError, ValueError):
    """An array has the wrong shape: the message names it, the expected and the found shape."""


class DomainError(PostcaptureError, ValueError):
    """A value lies outside the domain of a function (for example a parameter outside a sigmoid's range)."""


class CovarianceError(PostcaptureError, ValueError):
    """A covariance matrix is not finite or not symmetric positive definite; the message names it."""


class TimeGridError(PostcaptureError, ValueError):
    """Requested instants are not on a time grid (sensor sample times not on the truth grid, ...)."""


class SimulationError(PostcaptureError, RuntimeError):
    """The integration failed (Newton did not converge, a state became non-finite, ...)."""


class CompileError(PostcaptureError, RuntimeError):
    """The compiled plant core could not be built or loaded; the message names the cause and the fix."""


class FilterDivergenceError(PostcaptureError, RuntimeError):
    """A filter diverged. Carries the filter name, the time and the cause."""

    def __init__(self, filter_name: str, time: float, cause: str):
        self.filter_name = filter_name
        self.time = time
        self.cause = cause
        super().__init__(f"filter {filter_name!r} diverged at t = {time:.6g} s: {cause}")


class FMIError(PostcaptureError, RuntimeError):
    """An FMI call failed, or an FMU or mapping is unusable.

    Attributes
    ----------
    fmu : str
        The FMU file (or model name).
    function : str or None
        The FMI function or operation that failed.
    status : str or None
        The FMI status returned (``"Error"``, ``"Discard"``, ...), when there is one.
    """

    def __init__(self, message: str, fmu: str = "", function: str | None = None, status: str | None = None):
        self.fmu = fmu
        self.function = function
        self.status = status
        where = f"{fmu}: " if fmu else ""
        call = f"{function}" if function else ""
        stat = f" returned {status}" if status else ""
        prefix = f"{where}{call}{stat}: " if (call or stat) else where
        super().__init__(f"{prefix}{message}")


class MissingExtraError(PostcaptureError, ImportError):
    """An optional dependency is missing; the message names the pip extra that provides it."""

    def __init__(self, package: str, extra: str):
        self.package = package
        self.extra = extra
        super().__init__(
            f"{package} is not installed; install the optional extra: pip install 'postcapture[{extra}]'"
        )


class PanelModelError(ScenarioError):
    """A panel model (laminate, material, ply list, geometry or mesh) failed validation.

    A subclass of `ScenarioError` (and so of ``ValueError``): it carries every `Problem` found.

    Parameters
    ----------
    problems : list of Problem
        Every problem found, not only the first one.
    source : str, optional
        The file or name the description came from.
    """

    _what = "invalid panel model"


class NastranError(PostcaptureError, ValueError):
    """A Nastran file (BDF or OP2) cannot be used: the message names the file and what is missing.

    Attributes
    ----------
    path : str
        The file.
    """

    def __init__(self, message: str, path: str = ""):
        self.path = path
        super().__init__(f"{path}: {message}" if path else message)
