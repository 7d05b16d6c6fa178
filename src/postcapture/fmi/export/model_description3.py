"""Write the FMI 3.0 ``modelDescription.xml`` and ``sources/buildDescription.xml`` of an exported FMU.

The variables are the FMI 2.0 export's (:mod:`postcapture.fmi.export.interface`), as ``<Float64>``
elements, plus the independent variable ``time`` that FMI 3.0 requires; the capabilities are co-simulation
without event mode, with a variable communication step, FMU state (get, set, serialise) and directional
derivatives. ModelStructure names variables by value reference (FMI 2.0: by index) and lists the same
dependencies (:mod:`postcapture.fmi.export.structure`). FMI 3.0 moved the list of C sources out of the
model description into ``sources/buildDescription.xml``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from postcapture.fmi.export.interface import Interface
from postcapture.fmi.export.model_description import (
    DescriptionInfo,
    common_elements,
    number,
    plant_annotation,
    variable_attributes,
)

__all__ = ["write_model_description3", "write_build_description"]


def _xml(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def write_model_description3(interface: Interface, info: DescriptionInfo, dependencies: dict[int, list[int]]) -> str:
    """The XML text of an FMI 3.0 model description.

    Parameters
    ----------
    interface : Interface
        The variable table (with the ``time`` block).
    info : DescriptionInfo
        Names, instantiation token (``info.guid``), capabilities and default experiment.
    dependencies : dict of int to list of int
        For each value reference of an output or state derivative, the value references it depends on.

    Returns
    -------
    str
    """
    if "time" not in interface.blocks:
        raise ValueError("interface: an FMI 3.0 model description needs the independent variable time")
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": info.model_name, "instantiationToken": info.guid,
        "description": info.description, "generationTool": info.generation_tool, "variableNamingConvention": "flat",
    })
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": info.model_identifier,
        "canGetAndSetFMUState": "true",
        "canSerializeFMUState": "true",
        "providesDirectionalDerivatives": "true" if info.directional_derivatives else "false",
        "canHandleVariableCommunicationStepSize": "true",
        "hasEventMode": "false",
    })
    common_elements(root, interface, info)
    _variables(ET.SubElement(root, "ModelVariables"), interface)
    _structure(ET.SubElement(root, "ModelStructure"), interface, dependencies)
    note = ET.SubElement(ET.SubElement(root, "Annotations"), "Annotation", {"type": "postcapture"})
    ET.SubElement(note, "Plant", plant_annotation(interface, info))
    return _xml(root)


def _variables(mv: ET.Element, interface: Interface) -> None:
    for v in interface.variables:
        attrs = variable_attributes(v)
        if v.start is not None:
            attrs["start"] = number(v.start)
        if v.unit is not None:
            attrs["unit"] = v.unit
        if v.derivative is not None:  # FMI 3.0: the value reference of the state (FMI 2.0: its 1-based index)
            attrs["derivative"] = str(interface.variables[v.derivative - 1].valueReference)
        ET.SubElement(mv, "Float64", attrs)


def _structure(ms: ET.Element, interface: Interface, dependencies: dict[int, list[int]]) -> None:
    """Outputs, continuous-state derivatives and initial unknowns with their dependencies (value references)."""
    def unknown(tag: str, v) -> None:
        deps = " ".join(str(k) for k in dependencies[v.valueReference])
        ET.SubElement(ms, tag, {"valueReference": str(v.valueReference), "dependencies": deps})

    for v in interface.variables:
        if v.causality == "output":
            unknown("Output", v)
    for v in interface.variables:
        if v.block == "dx":
            unknown("ContinuousStateDerivative", v)
    for v in interface.variables:
        if v.block == "dx" or (v.causality == "output" and v.initial == "calculated"):
            unknown("InitialUnknown", v)


def write_build_description(model_identifier: str, sources: list[str]) -> str:
    """``sources/buildDescription.xml``: the C sources of the FMU's library and how to compile them."""
    root = ET.Element("fmiBuildDescription", {"fmiVersion": "3.0"})
    config = ET.SubElement(root, "BuildConfiguration", {"modelIdentifier": model_identifier})
    files = ET.SubElement(config, "SourceFileSet", {"language": "C99", "compilerOptions": "-ffp-contract=off"})
    for name in sources:
        ET.SubElement(files, "SourceFile", {"name": name})
    ET.SubElement(files, "PreprocessorDefinition", {"name": "PC_API", "value": "",
                                                    "description": "keep the plant core's symbols hidden"})
    return _xml(root)
