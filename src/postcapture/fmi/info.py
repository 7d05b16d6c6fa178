"""``fmu_info``: what an FMU offers (variables, capabilities) and what its mapping satisfies.

Backs ``postcapture fmu info FILE.fmu``: :func:`fmu_info` returns plain data (JSON-ready) and
:func:`format_fmu_info` the text table.
"""

from __future__ import annotations

import re
import textwrap
from collections import Counter
from pathlib import Path

from postcapture.core.errors import FMIError
from postcapture.fmi.description import read_description
from postcapture.fmi.mapping import Mapping, check_mapping, load_mapping

__all__ = ["MAPPING_NEEDS", "fmu_info", "format_fmu_info"]

MAPPING_NEEDS = (
    ("state.variables", "the state vector x, in order (readable variables, usually outputs)"),
    ("state.kinematics", "free_flyer (Pinocchio free flyer + joints) or quaternion (a unit q_BN in x)"),
    ("state.attitude", "q_BN (w, x, y, z): four entries of the state"),
    ("state.rate", "omega_BN_B (rad/s): three entries of the state"),
    ("state.velocity", "the chaser's linear velocity, B frame (m/s): three entries of the state (a free_flyer "
                       "state has it at v[1..3]); the filters reading the accelerometer's increments need it"),
    ("state.arm", "the arm's joint angles (rad): entries of the state; the recommended filters read the encoders"),
    ("correction.inputs", "inputs that replace the state at the next fmi2DoStep, same order as the state"),
    ("correction.reset", "input flag: > 0.5 at fmi2DoStep applies the correction"),
    ("measurement.accel", "chaser acceleration at the accelerometer, B components (m/s2)"),
    ("measurement.joint_accel", "arm joint accelerations (rad/s2)"),
    ("measurement.accelerometer_position", "where the accelerometer sits in B (m)"),
    ("parameters.mass", "a variable that is the target's mass (kg): a tunable parameter or an input; optional"),
    ("parameters.inputs", "inputs holding the plant's parameter vector (names: postcapture's names of them, "
                          "mass_offset: the target's mass beyond target.m); the recommended filters need them"),
    ("jacobians", "optional: request input and F, H (and g, h or G, Hp, valid) output name patterns"),
)

_ARRAY = re.compile(r"^(.*)\[([0-9]+)(?:,([0-9]+))?\](\)?)$")  # ASCII digits: int() reads any Unicode digit


def fmu_info(path: str | Path, mapping: str | Path | Mapping | None = None) -> dict:
    """Describe an FMU.

    Parameters
    ----------
    path : str or Path
        The ``.fmu`` file.
    mapping : str, Path or Mapping, optional
        A mapping to check; default: the embedded one or ``<fmu>.toml`` when present.

    Returns
    -------
    dict
        ``path``, ``fmi_version``, ``model_name``, ``guid``, ``generation_tool``, ``interfaces``,
        ``model_identifier``, ``capabilities`` (from the XML itself), ``binaries`` (``platform``,
        ``platforms``, ``sources``, ``problem``: why it cannot run here, or None),
        ``default_experiment``, ``variables`` (list of dicts with
        name, valueReference, causality, variability, unit, start, description), ``counts`` (per
        causality), ``mapping_needs`` and ``mapping`` (source, per-entry status, problems, satisfied,
        jacobians).

    Raises
    ------
    FMIError
        For a missing or unreadable file.
    """
    from postcapture.fmi.process_model import open_model_description

    md = open_model_description(path)
    desc = read_description(path)
    main = desc.interface("co-simulation") or (desc.interfaces[0] if desc.interfaces else None)
    variables = []
    for v in md.modelVariables:
        unit = v.unit if v.unit is not None else (v.declaredType.unit if v.declaredType is not None else None)
        variables.append(
            {
                "name": v.name,
                "valueReference": v.valueReference,
                "type": v.type,
                "causality": v.causality,
                "variability": v.variability,
                "unit": unit,
                "start": v.start,
                "description": v.description,
            }
        )
    de = md.defaultExperiment
    flags = main.flags if main is not None else {}
    binaries = {
        "platform": desc.platform,
        "platforms": list(desc.platforms),
        "sources": desc.has_sources,
        "problem": desc.binary_problem(main) if main is not None else "the FMU declares no interface",
    }
    info = {
        "path": str(path),
        "fmi_version": md.fmiVersion,
        "model_name": md.modelName,
        "guid": md.guid,
        "generation_tool": md.generationTool,
        "description": md.description,
        "interfaces": [i.kind for i in desc.interfaces],
        "model_identifier": main.model_identifier if main is not None else None,
        "capabilities": {  # read from the XML itself, by the spelling of the FMU's FMI version
            "canGetAndSetFMUstate": flags.get("can_get_and_set_fmu_state", False),
            "canSerializeFMUstate": flags.get("can_serialize_fmu_state", False),
            "providesDirectionalDerivative": flags.get("provides_directional_derivatives", False),
            "canHandleVariableCommunicationStepSize": flags.get("can_handle_variable_communication_step_size", False),
        },
        "binaries": binaries,
        "default_experiment": None
        if de is None
        else {"startTime": de.startTime, "stopTime": de.stopTime, "stepSize": de.stepSize},
        "variables": variables,
        "counts": dict(Counter(v["causality"] for v in variables)),
        "mapping_needs": [{"entry": e, "meaning": m} for e, m in MAPPING_NEEDS],
        "mapping": _mapping_status(md, desc, path, mapping),
    }
    return info


def _mapping_status(md, desc, path, mapping) -> dict:
    try:
        m = load_mapping(path, mapping)
    except FMIError as exc:  # none found (the error names the FMU), or found and invalid (it names the mapping)
        source = exc.fmu if exc.fmu != str(path) else None
        return {"source": source, "entries": [], "problems": [str(exc)], "satisfied": False, "jacobians": None}
    names = {v.name for v in md.modelVariables}
    entries = [{"entry": e, "variable": n, "found": n in names} for e, n in m.entries()]
    problems = check_mapping(m, md.modelVariables, str(path), len(m.state) - 1)
    cs = desc.interface("co-simulation")
    if cs is None:
        offered = " and ".join(i.kind for i in desc.interfaces) or "none"
        problems.append(f"the FMU has no co-simulation interface (it offers: {offered}); the filters need one")
    elif desc.binary_problem(cs):
        problems.append(f"it cannot run here: {desc.binary_problem(cs)}")
    if m.jacobians is not None:
        jac = "outputs (exact)"
    elif cs is not None and cs.flags["provides_directional_derivatives"]:
        jac = "directional derivatives (discretised)"
    elif cs is not None and cs.flags["can_get_and_set_fmu_state"]:
        jac = "finite differences over FMU states"
    else:
        jac = "none: the filters that need Jacobians cannot run"
    return {
        "source": m.source,
        "entries": entries,
        "problems": problems,
        "satisfied": not problems,
        "jacobians": jac,
    }


def _groups(variables: list[dict]):
    """Collapse ``name[i]`` / ``name[i,j]`` families into one row each."""
    rows, families = [], {}
    for v in variables:
        m = _ARRAY.match(v["name"])
        if m is None:
            rows.append((v["name"], v))
            continue
        base, i, j, tail = m.group(1), int(m.group(2)), m.group(3), m.group(4)
        key = (base, j is not None, v["causality"], tail)
        fam = families.get(key)
        if fam is None:
            fam = families[key] = {"first": v, "count": 0, "imax": 0, "jmax": 0}
            rows.append((key, fam))
        fam["count"] += 1
        fam["imax"] = max(fam["imax"], i)
        fam["jmax"] = max(fam["jmax"], int(j) if j else 0)
    out = []
    for key, item in rows:
        if isinstance(key, tuple):
            base, two, _, tail = key
            name = (
                f"{base}[1..{item['imax']},1..{item['jmax']}]{tail}"
                if two
                else f"{base}[1..{item['imax']}]{tail}"
            )
            v = dict(item["first"])
            v["description"] = f"({item['count']} variables; first: {v['description'] or ''})"
            v["name"] = name
            out.append(v)
        else:
            out.append(item)
    return out


def format_fmu_info(info: dict, width: int = 80) -> str:
    """Plain-text report of :func:`fmu_info`'s result, every line within ``width`` columns.

    Each variable (or family ``name[1..n]``) takes one line of name, causality, variability and
    unit, and its whole description on the lines below.
    """
    def wrap(text: str, indent: str) -> list[str]:
        return textwrap.wrap(text, width=width, initial_indent=indent, subsequent_indent=indent + "  ",
                             break_on_hyphens=False) or [indent.rstrip()]

    lines = wrap(f"{info['path']}: FMI {info['fmi_version']} {' + '.join(info['interfaces']) or 'no interface'}, "
                 f"model {info['model_name']!r} ({info['model_identifier']})", "")
    if info["generation_tool"]:
        lines += wrap(f"generated by {info['generation_tool']}", "  ")
    caps = ", ".join(f"{k}={'yes' if v else 'no'}" for k, v in info["capabilities"].items())
    lines += wrap(f"capabilities: {caps}", "  ")
    b = info.get("binaries")
    if b is not None:
        if b["problem"]:
            lines += wrap(f"binaries: NONE FOR THIS PLATFORM: {b['problem']}", "  ")
        else:
            lines += wrap(f"binaries: {', '.join(b['platforms'])} (this platform: {b['platform']})", "  ")
    if info["default_experiment"]:
        de = info["default_experiment"]
        lines += wrap(f"default experiment: {de['startTime']} .. {de['stopTime']} s, step {de['stepSize']} s", "  ")
    lines += wrap("variables: " + ", ".join(f"{n} {k}" for k, n in sorted(info["counts"].items())), "  ")
    lines.append("")
    lines.append(f"  {'name':<32} {'causality':<10} {'variability':<12} unit")
    lines.append("      description")
    for v in _groups(info["variables"]):
        lines.append(f"  {v['name']:<32} {v['causality']:<10} {v['variability']:<12} {v['unit'] or ''}".rstrip())
        if v["description"]:
            lines += wrap(v["description"], "      ")
    lines.append("")
    mp = info["mapping"]
    if mp["source"] is None:
        lines.append("  mapping: none found. A mapping (TOML) names:")
        for need in info["mapping_needs"]:
            lines.append(f"    {need['entry']}")
            lines += wrap(need["meaning"], "        ")
    else:
        status = "satisfied" if mp["satisfied"] else "NOT satisfied"
        jac = f"; Jacobians from {mp['jacobians']}" if mp["jacobians"] else ""
        lines += wrap(f"mapping {mp['source']}: {status}{jac}", "  ")
    for p in mp["problems"]:
        lines += wrap(f"- {p}", "    ")
    return "\n".join(lines)
