"""The FMI 3.0 model description of an estimator FMU (:mod:`postcapture.studies.estimator_fmu`).

The variables are the FMI 2.0 export's, as ``<Float64>`` elements with the same value references, plus the
independent variable ``time`` that FMI 3.0 requires, after them (value reference = the number of the
others; the C instance reads it as the time of the estimates). The capabilities: co-simulation without
event mode, FMU state (get, set, serialise), no directional derivatives, and a fixed communication step,
the filter's period (``canHandleVariableCommunicationStepSize="false"``, ``fixedInternalStepSize`` and the
default experiment's ``stepSize``): a step of another size returns ``fmi3Error``. The C sources are listed
in ``sources/buildDescription.xml`` (:func:`postcapture.fmi.export.model_description3.write_build_description`).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

from postcapture.config.schema import Scenario
from postcapture.fmi.export.interface import UNITS
from postcapture.fmi.export.model_description import number
from postcapture.fmi.export.model_description3 import write_build_description

__all__ = ["write_description3", "model_description3"]

_MORE_UNITS = {"rad2": {"rad": 2}}  # the star tracker's noise covariance
_CAUSALITY = {0: "input", 1: "parameter", 2: "output"}


def write_description3(root: Path, layout, ident: str, guid: str, case: str, scenario: Scenario, period: float,
                       sources: list[str]) -> None:
    """Write ``modelDescription.xml`` and ``sources/buildDescription.xml`` under the FMU tree ``root``."""
    (root / "modelDescription.xml").write_text(model_description3(layout, ident, guid, case, scenario, period))
    (root / "sources" / "buildDescription.xml").write_text(write_build_description(ident, list(sources)))


def _attributes(vr: int, v) -> dict:
    """The XML attributes of one estimator variable (an ``EstimatorVariable``) as a ``<Float64>``."""
    kind = _CAUSALITY[v.causality]
    attrs = {"name": v.name, "valueReference": str(vr), "causality": kind}
    if v.description:
        attrs["description"] = v.description
    if kind == "parameter":
        attrs["variability"] = "tunable" if v.tunable else "fixed"
    else:
        attrs["variability"] = "discrete"
    if kind == "output":
        attrs["initial"] = "calculated"
    else:
        attrs["start"] = number(v.start)
    if v.unit:
        attrs["unit"] = v.unit
    return attrs


def model_description3(layout, ident: str, guid: str, case: str, scenario: Scenario, period: float) -> str:
    """The XML text of the FMI 3.0 model description of an estimator FMU.

    Parameters
    ----------
    layout
        The variable table (``estimator_variables``): value reference = position.
    ident, guid : str
        Model identifier and instantiation token (the binary's ``PCE_GUID``).
    case : str
        The scheme.
    scenario : Scenario
        For the names and the default experiment's stop time.
    period : float
        The filter's period (s): the only communication step the FMU takes.

    Returns
    -------
    str
    """
    from postcapture._version import __version__

    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": f"{scenario.name} {case} estimator", "instantiationToken": guid,
        "description": f"postcapture {case} estimator of scenario {scenario.name}: one doStep is one filter cycle",
        "generationTool": f"postcapture {__version__}", "variableNamingConvention": "structured"})
    ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": ident, "canGetAndSetFMUState": "true", "canSerializeFMUState": "true",
        "providesDirectionalDerivatives": "false", "canHandleVariableCommunicationStepSize": "false",
        "fixedInternalStepSize": number(period), "hasEventMode": "false"})
    units = sorted({v.unit for v in layout.variables if v.unit})
    if units:
        defs = ET.SubElement(root, "UnitDefinitions")
        for name in units:
            exponents = UNITS.get(name, _MORE_UNITS.get(name))
            unit = ET.SubElement(defs, "Unit", {"name": name})
            if exponents is not None:
                ET.SubElement(unit, "BaseUnit", {k: str(e) for k, e in exponents.items()})
    cats = ET.SubElement(root, "LogCategories")
    ET.SubElement(cats, "Category", {"name": "logStatusError", "description": "errors"})
    ET.SubElement(root, "DefaultExperiment", {"startTime": "0.0", "stopTime": number(scenario.simulation.duration),
                                              "stepSize": number(period)})
    mv = ET.SubElement(root, "ModelVariables")
    n = len(layout.variables)
    ET.SubElement(mv, "Float64", {"name": "time", "valueReference": str(n), "causality": "independent",
                                  "variability": "continuous", "description": "time of the estimates"})
    for vr, v in enumerate(layout.variables):
        ET.SubElement(mv, "Float64", _attributes(vr, v))
    ms = ET.SubElement(root, "ModelStructure")
    outputs = [vr for vr, v in enumerate(layout.variables) if _CAUSALITY[v.causality] == "output"]
    for tag in ("Output", "InitialUnknown"):
        for vr in outputs:
            ET.SubElement(ms, tag, {"valueReference": str(vr)})
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"
