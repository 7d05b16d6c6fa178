"""What an FMU declares, read from its ``modelDescription.xml`` itself: interfaces, capability flags,
and the binaries it ships.

FMPy's model description is used for the variables, but it reads interface attributes by their FMI 2.0
spelling and so drops some FMI 3.0 flags (``providesDirectionalDerivatives`` with an ``s``, for
example); here every flag is read by the spelling of the FMU's own FMI version and reported under one
neutral name.
"""

from __future__ import annotations

import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from xml.etree import ElementTree

from postcapture.core.errors import FMIError
from postcapture.fmi._extras import import_fmpy

__all__ = ["INTERFACES", "Interface", "FMUDescription", "read_description"]

INTERFACES = {"CoSimulation": "co-simulation", "ModelExchange": "model-exchange",
              "ScheduledExecution": "scheduled-execution"}
"""XML element of each FMI interface and the name postcapture reports it by."""

# neutral name -> (FMI 2.0 attribute, FMI 3.0 attribute)
_FLAGS = {
    "can_get_and_set_fmu_state": ("canGetAndSetFMUstate", "canGetAndSetFMUState"),
    "can_serialize_fmu_state": ("canSerializeFMUstate", "canSerializeFMUState"),
    "provides_directional_derivatives": ("providesDirectionalDerivative", "providesDirectionalDerivatives"),
    "provides_adjoint_derivatives": (None, "providesAdjointDerivatives"),
    "can_handle_variable_communication_step_size": ("canHandleVariableCommunicationStepSize",
                                                     "canHandleVariableCommunicationStepSize"),
}
_MAX_XML_BYTES = 256 * 2**20


@dataclass(frozen=True)
class Interface:
    """One interface element of a model description.

    Attributes
    ----------
    kind : {"co-simulation", "model-exchange", "scheduled-execution"} or the element's own tag
    model_identifier : str
        The library name of this interface.
    flags : dict of str to bool
        Capability flags under neutral names (see ``_FLAGS``), False when absent.
    """

    kind: str
    model_identifier: str
    flags: dict = field(default_factory=dict)


@dataclass(frozen=True)
class FMUDescription:
    """Version, interfaces and binaries of an FMU archive.

    Attributes
    ----------
    fmi_version : str
    interfaces : tuple of Interface
        In the order of the XML.
    platform : str
        This machine's binary folder name for the FMU's FMI version (``linux64`` or ``x86_64-linux``).
    platforms : tuple of str
        Binary folders present in the archive.
    has_sources : bool
        Whether the archive ships C sources.
    """

    fmi_version: str
    interfaces: tuple
    platform: str
    platforms: tuple
    has_sources: bool
    library_suffix: str = ".so"
    _files: frozenset = field(default=frozenset(), repr=False)

    def interface(self, kind: str) -> Interface | None:
        """The interface of that kind (``"co-simulation"``, ...), or None."""
        return next((i for i in self.interfaces if i.kind == kind), None)

    def has_binary(self, interface: Interface) -> bool:
        """Whether the archive holds the library of ``interface`` for this platform."""
        return f"binaries/{self.platform}/{interface.model_identifier}{self.library_suffix}" in self._files

    def binary_problem(self, interface: Interface) -> str | None:
        """Why ``interface`` cannot run here (no binary for this platform), or None."""
        if self.has_binary(interface):
            return None
        others = ", ".join(p for p in self.platforms if p != self.platform) or "none"
        hint = "; it ships C sources (`fmpy compile` can build them)" if self.has_sources else ""
        return (f"no binary for this platform ({self.platform}: expected binaries/{self.platform}/"
                f"{interface.model_identifier}{self.library_suffix}); platforms it has: {others}{hint}")


def _flag(element, name: str | None) -> bool:
    return name is not None and element.get(name, "false").strip() in ("true", "1")


def read_description(path: str | Path) -> FMUDescription:
    """Read interfaces, capability flags and binaries of an FMU archive.

    Raises
    ------
    FMIError
        When the file is not a ZIP archive or has no readable ``modelDescription.xml``.
    """
    fmpy = import_fmpy()
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as zf:
            files = frozenset(zf.namelist())
            info = zf.getinfo("modelDescription.xml")
            if info.file_size > _MAX_XML_BYTES:
                raise FMIError(f"modelDescription.xml is {info.file_size} bytes", fmu=str(path), function="open")
            root = ElementTree.fromstring(zf.read(info))
    except KeyError:
        raise FMIError("no modelDescription.xml in the archive", fmu=str(path), function="open") from None
    except (zipfile.BadZipFile, OSError) as exc:
        raise FMIError(f"not a readable ZIP archive (an FMU is one): {exc}", fmu=str(path), function="open") from None
    except ElementTree.ParseError as exc:
        raise FMIError(f"modelDescription.xml is not well-formed XML: {exc}", fmu=str(path), function="open") from None
    version = root.get("fmiVersion", "")
    v3 = version.startswith("3")
    interfaces = []
    for element in root:
        if element.tag not in INTERFACES:
            continue
        flags = {key: _flag(element, names[1] if v3 else names[0]) for key, names in _FLAGS.items()}
        interfaces.append(Interface(INTERFACES[element.tag], element.get("modelIdentifier", ""), flags))
    platforms = tuple(sorted({n.split("/")[1] for n in files if n.startswith("binaries/") and n.count("/") >= 2
                              and not n.endswith("/")}))
    return FMUDescription(
        fmi_version=version,
        interfaces=tuple(interfaces),
        platform=fmpy.platform_tuple if v3 else fmpy.platform,
        platforms=platforms,
        has_sources=any(n.startswith("sources/") and n.endswith(".c") for n in files),
        library_suffix=fmpy.sharedLibraryExtension,
        _files=files,
    )
