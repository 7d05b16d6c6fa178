"""Write the FMI 2.0 ``modelDescription.xml`` of an exported FMU.

ModelStructure: every output, every state derivative and every initial unknown (the calculated outputs
and the state derivatives) with its ``dependencies`` (:mod:`postcapture.fmi.export.structure`; FMI 2.0
gives them as 1-based variable indices): without the attribute a master must assume that each depends
on every known, which made OMSimulator spend about 90 s building its graph.
:class:`DescriptionInfo`, :func:`common_elements` and :func:`plant_annotation` serve the FMI 3.0 writer too
(:mod:`postcapture.fmi.export.model_description3`).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

from postcapture.fmi.export.interface import UNITS, Interface

__all__ = ["DescriptionInfo", "write_model_description", "common_elements", "plant_annotation", "number",
           "variable_attributes"]


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
    internal_step: float = 0.0  # the integrator's largest step (s)


def number(x: float) -> str:
    """A real as the XML writes it (``repr``: every double round-trips)."""
    return repr(float(x))



def common_elements(root: ET.Element, interface: Interface, info: DescriptionInfo) -> None:
    """What FMI 2.0 and 3.0 write alike after the interface element: ``<UnitDefinitions>`` (each unit the
    variables use, in SI base units), ``<LogCategories>`` and ``<DefaultExperiment>``."""
    units = ET.SubElement(root, "UnitDefinitions")
    for name in sorted({v.unit for v in interface.variables if v.unit is not None}):
        unit = ET.SubElement(units, "Unit", {"name": name})
        ET.SubElement(unit, "BaseUnit", {k: str(e) for k, e in UNITS[name].items()})
    cats = ET.SubElement(root, "LogCategories")
    ET.SubElement(cats, "Category", {"name": "logStatusError", "description": "errors"})
    ET.SubElement(cats, "Category", {"name": "logEvents", "description": "information"})
    ET.SubElement(root, "DefaultExperiment",
                  {"startTime": "0.0", "stopTime": number(info.stop_time), "stepSize": number(info.step)})


def plant_annotation(interface: Interface, info: DescriptionInfo) -> dict:
    """Attributes of the vendor annotation ``<Plant>``: what postcapture's importer reads of the export."""
    return {"scenario": info.scenario, "variant": info.variant, "integrator": info.integrator,
            "step": number(info.internal_step), "stateCorrection": "x_corr + reset",
            "stepJacobian": "true" if interface.step_jacobian else "false", "parameters": "inputs"}


def write_model_description(interface: Interface, info: DescriptionInfo, dependencies: dict[int, list[int]]) -> str:
    """The XML text.

    Parameters
    ----------
    interface : Interface
        The variable table.
    info : DescriptionInfo
        Names, GUID, capabilities and default experiment.
    dependencies : dict of int to list of int
        For each value reference of an output or a state derivative, the value references of the knowns
        (states, inputs) it depends on (:func:`postcapture.fmi.export.structure.dependencies`).

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
    common_elements(root, interface, info)
    tool = ET.SubElement(ET.SubElement(root, "VendorAnnotations"), "Tool", {"name": "postcapture"})
    ET.SubElement(tool, "Plant", plant_annotation(interface, info))
    return root


def variable_attributes(v) -> dict:
    """The attributes every FMI version gives a variable: name, value reference, description, causality,
    variability and (when it has one) initial."""
    attrs = {"name": v.name, "valueReference": str(v.valueReference), "description": v.description,
             "causality": v.causality, "variability": v.variability}
    if v.initial is not None:
        attrs["initial"] = v.initial
    return attrs


def _variables(mv: ET.Element, interface: Interface) -> None:
    for v in interface.variables:
        sv = ET.SubElement(mv, "ScalarVariable", variable_attributes(v))
        real = {}
        if v.start is not None:
            real["start"] = number(v.start)
        if v.unit is not None:
            real["unit"] = v.unit
        if v.derivative is not None:
            real["derivative"] = str(v.derivative)
        ET.SubElement(sv, "Real", real)


def _structure(ms: ET.Element, interface: Interface, dependencies: dict[int, list[int]]) -> None:
    """Outputs, derivatives and initial unknowns with their dependencies (1-based variable indices)."""
    index = {v.valueReference: i + 1 for i, v in enumerate(interface.variables)}

    def unknown(parent, v) -> None:
        deps = " ".join(str(index[k]) for k in dependencies[v.valueReference])
        ET.SubElement(parent, "Unknown", {"index": str(index[v.valueReference]), "dependencies": deps})

    outputs = ET.SubElement(ms, "Outputs")
    for v in interface.variables:
        if v.causality == "output":
            unknown(outputs, v)
    ders = ET.SubElement(ms, "Derivatives")
    for v in interface.variables:
        if v.block == "dx":
            unknown(ders, v)
    init = ET.SubElement(ms, "InitialUnknowns")
    for v in interface.variables:
        if v.block == "dx" or (v.causality == "output" and v.initial == "calculated"):
            unknown(init, v)
