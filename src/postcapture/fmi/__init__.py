"""FMI: export of the plant as a co-simulation FMU, and FMU-backed process models (FMPy).

``import postcapture.fmi`` needs neither CasADi nor FMPy; the functions that use them import them when
called and raise :class:`~postcapture.core.errors.MissingExtraError` (extra ``fmi``) when missing.

* :func:`export_fmu` writes an FMI 2.0 co-simulation FMU of a scenario's plant (compiled C).
* :class:`FMUProcessModel` runs the filters on any FMI 2.0 / 3.0 co-simulation FMU.
* :class:`Mapping` names the FMU variables a filter uses; :func:`load_mapping` finds it.
* :func:`fmu_info` / :func:`format_fmu_info` describe an FMU and what its mapping satisfies.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

__all__ = [
    "ExportReport",
    "export_fmu",
    "FMUProcessModel",
    "Mapping",
    "load_mapping",
    "fmu_info",
    "format_fmu_info",
]

_LAZY = {
    "ExportReport": "postcapture.fmi.export.exporter",
    "export_fmu": "postcapture.fmi.export.exporter",
    "FMUProcessModel": "postcapture.fmi.process_model",
    "Mapping": "postcapture.fmi.mapping",
    "load_mapping": "postcapture.fmi.mapping",
    "fmu_info": "postcapture.fmi.info",
    "format_fmu_info": "postcapture.fmi.info",
}

if TYPE_CHECKING:  # pragma: no cover
    from postcapture.fmi.export.exporter import ExportReport, export_fmu
    from postcapture.fmi.info import fmu_info, format_fmu_info
    from postcapture.fmi.mapping import Mapping, load_mapping
    from postcapture.fmi.process_model import FMUProcessModel


def __getattr__(name: str):
    """Import the public names on first use (keeps ``import postcapture.fmi`` light)."""
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'postcapture.fmi' has no attribute {name!r}")
