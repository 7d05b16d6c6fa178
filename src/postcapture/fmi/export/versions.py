"""What differs between an FMI 2.0 and an FMI 3.0 export: the wrapper, the headers, the binary folder and
the model description. Everything else (the plant, its variables, the shared instance ``pc_fmu.c``, the
data header, the compilation) is one implementation for both.
"""

from __future__ import annotations

import platform
import sys
from collections.abc import Callable
from dataclasses import dataclass

from postcapture.core.errors import FMIError

__all__ = ["FMIVersion", "VERSIONS", "SHARED_SOURCES"]

SHARED_SOURCES = ("pc_fmu.c", "pc_fmu.h")
"""The instance both wrappers drive (``fmi/csrc``)."""


def _fmi2_folder() -> str:
    if sys.platform.startswith("linux"):
        return "linux64" if sys.maxsize > 2**32 else "linux32"
    raise FMIError(f"exporting FMUs is supported on Linux only, not {sys.platform}", function="export")


def _fmi3_folder() -> str:
    if sys.platform.startswith("linux"):
        machine = {"amd64": "x86_64", "arm64": "aarch64"}.get(platform.machine().lower(), platform.machine().lower())
        return f"{machine}-linux"
    raise FMIError(f"exporting FMUs is supported on Linux only, not {sys.platform}", function="export")


@dataclass(frozen=True)
class FMIVersion:
    """One FMI version's part of an export.

    Attributes
    ----------
    number : int
        2 or 3.
    name : str
        ``fmiVersion`` (``"2.0"``, ``"3.0"``).
    wrapper : str
        The C file mapping that version's calls onto the shared instance.
    wrapper_common : str
        The header of the calls the plant's and the estimator's wrappers of that version map alike
        (``fmi/csrc``, included by the wrapper).
    headers : tuple of str
        The standard's headers (from FMPy's ``c-code``).
    binary_folder : callable
        ``() -> str``: the folder under ``binaries/`` for this machine.
    independent_time : bool
        Whether the variables include the independent variable ``time``.
    """

    number: int
    name: str
    wrapper: str
    wrapper_common: str
    headers: tuple[str, ...]
    binary_folder: Callable[[], str]
    independent_time: bool


VERSIONS = {
    2: FMIVersion(2, "2.0", "pc_fmi2.c", "pc_fmi2_common.h",
                  ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"), _fmi2_folder, False),
    3: FMIVersion(3, "3.0", "pc_fmi3.c", "pc_fmi3_common.h",
                  ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h"), _fmi3_folder, True),
}
