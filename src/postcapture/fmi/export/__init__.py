"""Export of the plant as an FMI co-simulation FMU (compiled C, no Python inside)."""

from postcapture.fmi.export.exporter import ExportReport, export_fmu

__all__ = ["ExportReport", "export_fmu"]
