"""``write_ssp``: an SSP 1.0 archive (System Structure and Parameterization) composing co-simulation FMUs.

The archive holds ``SystemStructure.ssd`` and the FMUs under ``resources/``. Its one system is
weakly coupled: each FMU is a component, each connection routes an output (of a component, or an input of
the system itself) to one component input, and inputs held constant are bound to a value with an inline
``ssv:ParameterSet``. Only the connectors that a connection or a binding uses are declared on a component;
the rest keep their start values.

Every connector is checked against the FMU's ``modelDescription.xml`` before anything is written: a
connection from or to a variable the FMU lacks, or with the wrong causality, raises :class:`FMIError` naming
it. FMI 2.0 co-simulation FMUs only (what OMSimulator, the SSP master built here, reads).

OMSimulator reads its master settings from a vendor annotation (``org.openmodelica``): the fixed
communication step (written with every digit, ``repr``), and a signal filter (``resources/signalFilter.xml``,
one ``oms:Variable`` per signal kept in its result file). Other SSP tools ignore both. OMSimulator's
command line takes the stop time from ``--stopTime`` (default 1 s) whatever the archive says.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

from postcapture.core.errors import FMIError
from postcapture.io import write_atomic

__all__ = ["SSPConnection", "SSPComponent", "fmu_variables", "write_ssp", "SSD_NAMESPACES"]

SSD_NAMESPACES = {
    "ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
    "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
    "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
    "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd",
}
_FMU_TYPE = "application/x-fmu-sharedlibrary"


@dataclass(frozen=True)
class SSPConnection:
    """One connection: ``start`` is a component (``""`` for the system's own input) and its connector."""

    start_element: str
    start_connector: str
    end_element: str
    end_connector: str

    def __str__(self) -> str:
        start = f"{self.start_element}.{self.start_connector}" if self.start_element else self.start_connector
        return f"{start} -> {self.end_element}.{self.end_connector}"


@dataclass(frozen=True)
class SSPComponent:
    """One FMU of the system: its name in the SSD, the file and the inputs held at a constant value."""

    name: str
    fmu: Path
    bindings: dict = field(default_factory=dict)


def fmu_variables(path: str | Path) -> tuple[str, dict, dict]:
    """The FMI version of an FMU, its variables ``name -> (causality, unit)`` and its unit definitions
    ``unit -> {base unit: exponent}`` (``None`` without a ``BaseUnit``), FMI 2.0 layout."""
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as z:
            root = ET.fromstring(z.read("modelDescription.xml"))
    except (OSError, KeyError, zipfile.BadZipFile, ET.ParseError) as exc:
        raise FMIError(f"{path}: not a readable FMU ({exc})", fmu=str(path)) from exc
    out = {}
    for sv in root.iter("ScalarVariable"):
        real = sv.find("Real")
        out[sv.get("name")] = (sv.get("causality", "local"), real.get("unit", "") if real is not None else "")
    units = {}
    for unit in root.iter("Unit"):
        base = unit.find("BaseUnit")
        units[unit.get("name")] = None if base is None else dict(base.attrib)
    return root.get("fmiVersion", ""), out, units


def _qualified(prefix: str, tag: str) -> str:
    return f"{{{SSD_NAMESPACES[prefix]}}}{tag}"


def _connector(parent, name: str, kind: str, unit: str, units: dict, declared: set) -> None:
    """A real connector; its unit only when its definition is known (an SSD unit names an ``ssd:Units``
    entry, which OMSimulator compares across a connection by base units)."""
    c = ET.SubElement(parent, _qualified("ssd", "Connector"), {"name": name, "kind": kind})
    if unit and units.get(unit) is not None:
        declared.add(unit)
        ET.SubElement(c, _qualified("ssc", "Real"), {"unit": unit})
    else:
        ET.SubElement(c, _qualified("ssc", "Real"))


def _check(components: list[SSPComponent], connections: list[SSPConnection], system_inputs: dict,
           results: list[str]) -> tuple[dict, dict]:
    """Every connector exists with the right causality; returns each FMU's variables and the unit
    definitions of all of them (the first with base units for each name)."""
    variables, units = {}, {}
    for comp in components:
        version, table, defs = fmu_variables(comp.fmu)
        for unit, base in defs.items():
            if units.get(unit) is None:
                units[unit] = base
        if not version.startswith("2."):
            raise FMIError(f"component {comp.name!r}: an FMI 2.0 FMU is needed in this SSP, found fmiVersion "
                           f"{version!r}", fmu=str(comp.fmu))
        variables[comp.name] = table
        for name in comp.bindings:
            if table.get(name, ("",))[0] not in ("input", "parameter"):
                raise FMIError(f"binding {comp.name}.{name}: no input or parameter of that name in the FMU",
                               fmu=str(comp.fmu))
    for con in connections:
        if con.start_element == "":
            if con.start_connector not in system_inputs:
                raise FMIError(f"connection {con}: the system has no input {con.start_connector!r}")
        elif variables.get(con.start_element, {}).get(con.start_connector, ("",))[0] != "output":
            raise FMIError(f"connection {con}: {con.start_connector!r} is not an output of {con.start_element!r}")
        if variables.get(con.end_element, {}).get(con.end_connector, ("",))[0] != "input":
            raise FMIError(f"connection {con}: {con.end_connector!r} is not an input of {con.end_element!r}")
    ends = [(c.end_element, c.end_connector) for c in connections]
    twice = sorted({f"{e}.{n}" for e, n in ends if ends.count((e, n)) > 1})
    if twice:
        raise FMIError(f"connections: inputs fed twice: {', '.join(twice)}")
    _check_results(results, variables, system_inputs)
    return variables, units


def _check_results(results: list[str], variables: dict, system_inputs: dict) -> None:
    for signal in results:
        element, _, var = signal.partition(".")
        if element in variables and var not in variables[element]:
            raise FMIError(f"results: {element!r} has no variable {var!r}")
        if element not in variables and signal not in system_inputs:
            raise FMIError(f"results: no component nor system input {signal!r}")


def _ssd(name: str, components, connections, system_inputs: dict, variables: dict, units: dict, step: float,
         stop: float, results: list[str], signal_filter: str | None) -> ET.Element:
    for prefix, uri in SSD_NAMESPACES.items():
        ET.register_namespace(prefix, uri)
    root = ET.Element(_qualified("ssd", "SystemStructureDescription"), {"name": name, "version": "1.0"})
    system = ET.SubElement(root, _qualified("ssd", "System"), {"name": "root"})
    declared = set()
    if system_inputs:
        conns = ET.SubElement(system, _qualified("ssd", "Connectors"))
        for input_name, unit in system_inputs.items():
            _connector(conns, input_name, "input", unit, units, declared)
    elements = ET.SubElement(system, _qualified("ssd", "Elements"))
    for comp in components:
        table = variables[comp.name]
        used = [c.start_connector for c in connections if c.start_element == comp.name]
        used += [c.end_connector for c in connections if c.end_element == comp.name] + list(comp.bindings)
        used += [r.partition(".")[2] for r in results if r.partition(".")[0] == comp.name]
        el = ET.SubElement(elements, _qualified("ssd", "Component"),
                           {"name": comp.name, "type": _FMU_TYPE, "source": f"resources/{comp.name}.fmu"})
        conns = ET.SubElement(el, _qualified("ssd", "Connectors"))
        for var in dict.fromkeys(used):  # once each, in order
            _connector(conns, var, table[var][0], table[var][1], units, declared)
        if comp.bindings:
            binding = ET.SubElement(ET.SubElement(el, _qualified("ssd", "ParameterBindings")),
                                    _qualified("ssd", "ParameterBinding"))
            pset = ET.SubElement(ET.SubElement(binding, _qualified("ssd", "ParameterValues")),
                                 _qualified("ssv", "ParameterSet"), {"version": "1.0", "name": "constants"})
            params = ET.SubElement(pset, _qualified("ssv", "Parameters"))
            for var, value in comp.bindings.items():
                p = ET.SubElement(params, _qualified("ssv", "Parameter"), {"name": var})
                ET.SubElement(p, _qualified("ssv", "Real"), {"value": repr(float(value))})
    links = ET.SubElement(system, _qualified("ssd", "Connections"))
    for con in connections:  # no startElement: the system's own connector
        start = {"startElement": con.start_element} if con.start_element else {}
        ET.SubElement(links, _qualified("ssd", "Connection"), {
            **start, "startConnector": con.start_connector, "endElement": con.end_element,
            "endConnector": con.end_connector})
    master = _oms_annotation(system)
    ET.SubElement(master, _qualified("oms", "FixedStepMaster"),
                  {"description": "oms-ma", "stepSize": repr(float(step)), "relativeTolerance": "0.0001"})
    if declared:
        defs = ET.SubElement(root, _qualified("ssd", "Units"))
        for unit in sorted(declared):
            ET.SubElement(ET.SubElement(defs, _qualified("ssc", "Unit"), {"name": unit}),
                          _qualified("ssc", "BaseUnit"), units[unit])
    experiment = ET.SubElement(root, _qualified("ssd", "DefaultExperiment"),
                               {"startTime": "0.0", "stopTime": repr(float(stop))})
    if signal_filter is not None:
        _oms_annotation(experiment).set("signalFilter", signal_filter)
    ET.indent(root)
    return root


def _oms_annotation(parent) -> ET.Element:
    """An ``oms:SimulationInformation`` inside an ``org.openmodelica`` annotation of ``parent``."""
    note = ET.SubElement(ET.SubElement(parent, _qualified("ssd", "Annotations")), _qualified("ssc", "Annotation"),
                         {"type": "org.openmodelica"})
    return ET.SubElement(ET.SubElement(note, _qualified("oms", "Annotations")),
                         _qualified("oms", "SimulationInformation"))


def _filter(name: str, signals: list[str]) -> str:
    root = ET.Element(_qualified("oms", "SignalFilter"), {"version": "1.0"})
    for signal in signals:
        ET.SubElement(root, _qualified("oms", "Variable"), {"name": f"{name}.root.{signal}", "type": "Real"})
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def write_ssp(out_path: str | Path, *, name: str, components: list[SSPComponent], connections: list[SSPConnection],
              step: float, stop: float, system_inputs: dict | None = None, results: list[str] | None = None) -> Path:
    """Write an SSP 1.0 archive of one weakly coupled system of FMI 2.0 co-simulation FMUs.

    Parameters
    ----------
    out_path : str or Path
        The ``.ssp`` file to write.
    name : str
        The system structure's name (OMSimulator's model name: its signals are ``<name>.root.<element>.<var>``).
    components : list of SSPComponent
        The FMUs, stored as ``resources/<component name>.fmu``.
    connections : list of SSPConnection
    step : float
        The communication step (s).
    stop : float
        The default experiment's stop time (s).
    system_inputs : dict, optional
        The system's own inputs, ``name -> unit``.
    results : list of str, optional
        The signals OMSimulator keeps in its result file (``<element>.<var>``); all when omitted.

    Returns
    -------
    Path
        ``out_path``.

    Raises
    ------
    FMIError
        For a connector the FMU lacks, a wrong causality, an input fed twice or an FMU that is not FMI 2.0.
    OutputPathError
        When the archive cannot be written.
    ValueError
        For a step or a stop time that is not a positive number.
    """
    for field_name, value in (("step", step), ("stop", stop)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{field_name}: expected a positive finite time in seconds, found {value!r}")
    system_inputs = dict(system_inputs or {})
    names = [c.name for c in components]
    if len(set(names)) != len(names) or any(not n.isidentifier() for n in names):
        raise FMIError(f"components: names must be distinct identifiers, found {names}")
    variables, units = _check(components, connections, system_inputs, list(results or []))
    filter_path = "resources/signalFilter.xml" if results is not None else None
    ssd = _ssd(name, components, connections, system_inputs, variables, units, step, stop, list(results or []),
               filter_path)

    def write(tmp: str) -> None:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
            z.writestr("SystemStructure.ssd",
                       '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(ssd, encoding="unicode") + "\n")
            for comp in components:
                z.write(comp.fmu, f"resources/{comp.name}.fmu")
            if filter_path is not None:
                z.writestr(filter_path, _filter(name, results))

    return write_atomic(out_path, write)  # a failure never leaves half an archive
