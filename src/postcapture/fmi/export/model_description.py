"""Write the FMI 2.0 ``modelDescription.xml`` of an exported FMU.

ModelStructure: every output is listed; the state outputs, the named outputs and the state derivatives
without ``dependencies`` (they may depend on every known), or with the dependencies given, the Jacobian
outputs with none (``dependencies=""``: they describe the last communication step, not the current
knowns).
InitialUnknowns lists every calculated output and every state derivative.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

from postcapture.fmi.export.interface import UNITS, Interface

__all__ = ["DescriptionInfo", "write_model_description"]


@dataclass(frozen=True)
class DescriptionInfo:
    """Header facts of a model description."""

    model_name: str
    model_identifier: str
    guid: str
    description: str
    generation_tool: str
    directional_derivatives: bool
    source_files: tuple[str, ...]
    stop_time: float
    step: float
    integrator: str
    variant: str
    scenario: str


def _fmt(x: float) -> str:
    return repr(float(x))


def write_model_description(
    interface: Interface, info: DescriptionInfo, dependencies: dict[int, list[int]] | None = None
) -> str:
    """The XML text.

    Parameters
    ----------
    interface : Interface
        The variable table.
    info : DescriptionInfo
        Names, GUID, capabilities and default experiment.
    dependencies : dict of int to list of int, optional
        For each value reference of a state derivative or named output, the value references of the
        knowns (states, inputs) it depends on; None leaves the attribute out (FMI 2.0: it may depend
        on every known).

    Returns
    -------
    str
    """
    root = _header(interface, info)
    _variables(ET.SubElement(root, "ModelVariables"), interface)
    _structure(ET.SubElement(root, "ModelStructure"), interface, dependencies)
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _header(interface: Interface, info: DescriptionInfo) -> ET.Element:
    """The root element with the co-simulation capabilities, units, log categories, experiment, vendor data."""
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": info.model_name, "guid": info.guid, "description": info.description,
        "generationTool": info.generation_tool, "variableNamingConvention": "flat", "numberOfEventIndicators": "0",
    })
    cs = ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": info.model_identifier,
        "canHandleVariableCommunicationStepSize": "true",
        "canNotUseMemoryManagementFunctions": "true",
        "canGetAndSetFMUstate": "true",
        "canSerializeFMUstate": "true",
        "providesDirectionalDerivative": "true" if info.directional_derivatives else "false",
    })
    files = ET.SubElement(cs, "SourceFiles")
    for f in info.source_files:
        ET.SubElement(files, "File", {"name": f})
    units = ET.SubElement(root, "UnitDefinitions")
    for name in sorted({v.unit for v in interface.variables if v.unit is not None}):
        unit = ET.SubElement(units, "Unit", {"name": name})
        ET.SubElement(unit, "BaseUnit", {k: str(e) for k, e in UNITS[name].items()})
    cats = ET.SubElement(root, "LogCategories")
    ET.SubElement(cats, "Category", {"name": "logStatusError", "description": "errors"})
    ET.SubElement(cats, "Category", {"name": "logEvents", "description": "information"})
    ET.SubElement(root, "DefaultExperiment",
                  {"startTime": "0.0", "stopTime": _fmt(info.stop_time), "stepSize": _fmt(info.step)})
    tool = ET.SubElement(ET.SubElement(root, "VendorAnnotations"), "Tool", {"name": "postcapture"})
    ET.SubElement(tool, "Plant", {
        "scenario": info.scenario, "variant": info.variant, "integrator": info.integrator, "step": _fmt(info.step),
        "stateCorrection": "x_corr + reset", "stepJacobian": "true" if interface.step_jacobian else "false",
    })
    return root


def _variables(mv: ET.Element, interface: Interface) -> None:
    for v in interface.variables:
        attrs = {"name": v.name, "valueReference": str(v.valueReference), "description": v.description,
                 "causality": v.causality, "variability": v.variability}
        if v.initial is not None:
            attrs["initial"] = v.initial
        sv = ET.SubElement(mv, "ScalarVariable", attrs)
        real = {}
        if v.start is not None:
            real["start"] = _fmt(v.start)
        if v.unit is not None:
            real["unit"] = v.unit
        if v.derivative is not None:
            real["derivative"] = str(v.derivative)
        ET.SubElement(sv, "Real", real)


def _structure(ms: ET.Element, interface: Interface, dependencies: dict[int, list[int]] | None) -> None:
    """Outputs, derivatives and initial unknowns with their dependencies (1-based variable indices)."""
    index = {v.valueReference: i + 1 for i, v in enumerate(interface.variables)}

    def deps(v) -> str:
        return " ".join(str(index[k]) for k in dependencies[v.valueReference])

    outputs = ET.SubElement(ms, "Outputs")
    for v in interface.variables:
        if v.causality != "output":
            continue
        attrs = {"index": str(index[v.valueReference])}
        if v.block == "y" and dependencies is not None:
            attrs["dependencies"] = deps(v)
        elif v.block == "jac":
            attrs["dependencies"] = ""
        ET.SubElement(outputs, "Unknown", attrs)
    ders = ET.SubElement(ms, "Derivatives")
    for v in interface.variables:
        if v.block == "dx":
            attrs = {"index": str(index[v.valueReference])}
            if dependencies is not None:
                attrs["dependencies"] = deps(v)
            ET.SubElement(ders, "Unknown", attrs)
    init = ET.SubElement(ms, "InitialUnknowns")
    for v in interface.variables:
        if v.block == "dx" or (v.causality == "output" and v.initial == "calculated"):
            ET.SubElement(init, "Unknown", {"index": str(index[v.valueReference])})
