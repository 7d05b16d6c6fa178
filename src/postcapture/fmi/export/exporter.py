"""``export_fmu``: a scenario's plant as an FMI 2.0 or 3.0 co-simulation FMU with compiled C inside.

Steps: build the plant (:func:`~postcapture.dynamics.build.build_system`), pack it for the compiled
core (:func:`~postcapture.dynamics.packing.pack`), write the data header and ``modelDescription.xml``,
compile the core's sources with the shared FMU instance (``pc_fmu.c``) and the FMI version's wrapper
(:mod:`postcapture.fmi.export.versions`), write the mapping file, zip. The FMU runs the same C as the
native process model.
"""

from __future__ import annotations

import hashlib
import logging
import re
import shutil
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from postcapture.config.schema import Scenario, orbit_mean_motion
from postcapture.fmi._extras import import_fmpy
from postcapture.fmi.mapping import JacobianOutputs, Mapping, mapping_sidecar
from postcapture.io import check_output_file, scratch_folder, write_atomic

__all__ = ["ExportReport", "export_fmu"]

logger = logging.getLogger(__name__)

MAPPING_RESOURCE = "resources/postcapture_mapping.toml"


@dataclass(frozen=True)
class ExportReport:
    """What :func:`export_fmu` built.

    Attributes
    ----------
    path, mapping_path : Path
        The FMU and its mapping file (also embedded as ``resources/postcapture_mapping.toml``).
    model_identifier, guid : str
        C identifier (library name) and GUID of the FMU.
    fmi_version, variant, integrator : str
        ``"2.0"`` or ``"3.0"``, the model variant and the internal integrator.
    step : float
        Internal integrator step (s): the longest one a communication step is cut into.
    n_states, n_variables : int
        State size ``nx`` and number of FMI variables.
    seconds, seconds_codegen, seconds_compile : float
        Wall times (s): total, writing the sources, C compilation.
    c_bytes : int
        Size of the C sources.
    directional_derivatives, step_jacobian : bool
        Whether the FMU provides directional derivatives and the Jacobian outputs.
    instructions : dict
        Kept for compatibility (empty: nothing is generated per function any more).
    """

    path: Path
    mapping_path: Path
    model_identifier: str
    guid: str
    fmi_version: str
    variant: str
    integrator: str
    step: float
    n_states: int
    n_variables: int
    directional_derivatives: bool
    step_jacobian: bool
    seconds: float
    seconds_codegen: float
    seconds_compile: float
    c_bytes: int
    instructions: dict


def _identifier(text: str) -> str:
    ident = re.sub(r"[^A-Za-z0-9_]", "_", text)
    return ident if re.match(r"[A-Za-z_]", ident) else "m_" + ident


def export_fmu(
    scenario: Scenario | str | Path,
    out_path: str | Path,
    *,
    variant: str = "flexible",
    fmi_version: int = 2,
    directional_derivatives: bool = True,
    step_jacobian: bool = True,
    panel_segments: int | None = None,
    excitation: bool = True,
    integrator: str | None = None,
    step: float | None = None,
    model_identifier: str | None = None,
    lead: float = 0.0,
    progress: Callable[[str], None] | None = None,
) -> ExportReport:
    """Export the plant of a scenario as a co-simulation FMU.

    The plant is the filters' process model of the scenario: its ``[estimation]`` integrator and step,
    and the orbit's gravity gradient when ``[orbit] filters = "model"`` (free space otherwise).

    Parameters
    ----------
    scenario : Scenario, str or Path
        A scenario, or a built-in name or TOML path for :func:`postcapture.config.load_scenario`.
    out_path : str or Path
        The ``.fmu`` file to write; the mapping goes next to it as ``<stem>.mapping.toml``.
    variant : {"flexible", "stiff", "rigid"}
        Model variant (see :func:`postcapture.dynamics.assembly.assemble`).
    fmi_version : {2, 3}
        FMI version: 2.0 or 3.0 co-simulation, the same plant and variables.
    directional_derivatives : bool
        Provide ``fmi2GetDirectionalDerivative`` / ``fmi3GetDirectionalDerivative`` (continuous partials of
        the state derivatives and outputs with respect to the states and the inputs, the parameter inputs
        among them).
    step_jacobian : bool
        Add the exact step and measurement Jacobian outputs ``F``, ``G``, ``H``, ``Hp`` and
        ``jacobian_valid``.
    panel_segments : int, optional
        Cut every panel into this many segments.
    excitation : bool
        Embed the scenario's excitation profiles (False: only the FMU inputs drive the plant).
    integrator : {"sdirk3", "sdirk2", "rk4"}, optional
        Internal integrator (default: the scenario's).
    step : float, optional
        Internal integrator step (s) (default: the scenario's ``[estimation] model_step``): a
        communication step ``H`` is taken as ``n`` equal steps, ``n`` the fewest with ``H / n <= step``
        (a whole multiple of ``step`` in steps of exactly ``step``, as the native process model).
    model_identifier : str, optional
        C identifier and library name (default ``<scenario>_<variant>``).
    lead : float
        How far (s) the plant runs ahead of the master's clock (default 0: not at all). With ``lead > 0`` it
        flies ``[t0, t0 + lead]`` when leaving initialisation and a step from the master's ``t`` of ``H`` flies
        ``[t + lead, t + lead + H]``: at the master's ``t`` its outputs are the plant's at ``t + lead``. The
        SSP scheme sets it to the filter's period, so that a Jacobi master (OMSimulator's) hands the
        estimator's cycle ``[t_k, t_k+1]`` the sensors of that cycle (the star tracker and the encoders at
        its end, the means over it) instead of those one cycle older
        (:mod:`postcapture.studies.estimator_ssp`). Inputs set at the master's ``t`` act over the plant's
        ``[t + lead, t + lead + H]``.
    progress : callable, optional
        ``progress(message: str) -> None``, called at each stage.

    Returns
    -------
    ExportReport

    Raises
    ------
    FMIError
        When the C compiler is missing or compilation fails.
    ValueError
        For an unknown variant, integrator or FMI version.
    """
    from postcapture.fmi.export.versions import VERSIONS

    fmpy = import_fmpy()
    from postcapture.config import load_scenario
    from postcapture.dynamics.build import build_system, initial_state
    from postcapture.fmi.export.compiler import zip_fmu
    from postcapture.fmi.export.plant_info import ExportPlant

    say = progress or (lambda msg: None)
    t_start = time.perf_counter()
    if not isinstance(scenario, Scenario):
        scenario = load_scenario(scenario)
    integrator, step = _check_settings(scenario, fmi_version, integrator, step)
    if not (isinstance(lead, (int, float)) and 0.0 <= float(lead) < float("inf")):
        raise ValueError(f"lead: expected a finite number of seconds, at least 0, found {lead!r}")
    version = VERSIONS[fmi_version]
    out_path = check_output_file(out_path)
    check_output_file(mapping_sidecar(out_path))
    ident = _identifier(model_identifier or f"{scenario.name}_{variant}")
    say("building the plant")
    system = build_system(scenario, variant, panel_segments=panel_segments, excitation=excitation)
    q0, v0 = initial_state(system)
    plant = ExportPlant(system)
    settings = _Settings(variant, panel_segments, excitation, integrator, step, directional_derivatives, step_jacobian,
                         ident, version.number, orbit_mean_motion(scenario, "filters"), float(lead))
    guid = _guid(scenario, settings)
    with scratch_folder("postcapture_fmu") as tmp:  # a killed export's folder goes at the next export
        root = Path(tmp) / "fmu"
        say("writing the sources")
        t0 = time.perf_counter()
        interface, c_bytes = _write_sources(fmpy, root / "sources", plant, np.concatenate([q0, v0]), guid, settings,
                                            version)
        t_codegen = time.perf_counter() - t0
        say("compiling the shared library")
        t_compile = _compile(root, Path(tmp) / "build", ident, out_path, version)
        say("writing modelDescription.xml and the mapping")
        mapping = _write_description(root, scenario, interface, plant, guid, settings, version)
        zip_fmu(root, out_path)
    mapping_path = write_atomic(mapping_sidecar(out_path), lambda tmp: Path(tmp).write_text(mapping.to_toml()))
    total = time.perf_counter() - t_start
    logger.info("exported %s in %.1f s (codegen %.1f s, compile %.1f s)", out_path, total, t_codegen, t_compile)
    return ExportReport(
        path=out_path, mapping_path=mapping_path, model_identifier=ident, guid=guid, fmi_version=version.name,
        variant=variant, integrator=integrator, step=step, n_states=plant.nx, n_variables=len(interface.variables),
        directional_derivatives=directional_derivatives, step_jacobian=step_jacobian, seconds=total,
        seconds_codegen=t_codegen, seconds_compile=t_compile, c_bytes=c_bytes, instructions={},
    )


@dataclass(frozen=True)
class _Settings:
    """What an export was asked for (beyond the scenario)."""

    variant: str
    panel_segments: int | None
    excitation: bool
    integrator: str
    step: float
    directional: bool
    step_jacobian: bool
    ident: str
    fmi_version: int
    orbit: float  # rad/s: the mean motion of the orbit the filters' plant feels (0: free space)
    lead: float = 0.0  # s: how far the plant runs ahead of the master's clock


def _check_settings(scenario: Scenario, fmi_version, integrator, step) -> tuple[str, float]:
    from postcapture.dynamics.integrators import TABLEAUX

    if fmi_version not in (2, 3):
        raise ValueError(f"fmi_version: expected 2 or 3, found {fmi_version!r}")
    integrator = integrator or scenario.estimation.integrator  # the filters' process model
    if integrator not in TABLEAUX:
        raise ValueError(f"integrator: expected one of {sorted(TABLEAUX)}, found {integrator!r}")
    step = float(step if step is not None else scenario.estimation.model_step)
    if not step > 0:
        raise ValueError(f"step: expected a positive number of seconds, found {step}")
    return integrator, step


def _guid(scenario: Scenario, s: _Settings) -> str:
    """A GUID that changes with everything the FMU's binary depends on."""
    from postcapture._version import __version__

    key = hashlib.sha256("|".join([
        scenario.model_dump_json(), s.variant, str(s.panel_segments), str(s.excitation), s.integrator, repr(s.step),
        str(s.directional), str(s.step_jacobian), s.ident, str(s.fmi_version), repr(s.orbit), __version__,
        *([f"lead={s.lead!r}"] if s.lead else []),
    ]).encode()).hexdigest()
    return "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "postcapture:" + key)) + "}"


def _write_sources(fmpy, sources: Path, plant, x0: np.ndarray, guid: str, s: _Settings, version):
    """The data header, the core's sources, the FMU instance, the version's wrapper and headers; returns the
    interface and the bytes of C."""
    from postcapture.dynamics.compiled import source_files
    from postcapture.dynamics.integrators import TABLEAUX
    from postcapture.fmi.export.c_header import write_c_header
    from postcapture.fmi.export.interface import build_interface
    from postcapture.fmi.export.versions import SHARED_SOURCES

    sources.mkdir(parents=True)
    interface = build_interface(plant, x0, step_jacobian=s.step_jacobian, n_y=len(plant.output_signals()),
                                n_z=3 + plant.n_arm, independent_time=version.independent_time)
    header = write_c_header(plant, interface, guid=guid, tableau=TABLEAUX[s.integrator], step=s.step, x0=x0,
                            directional=s.directional, orbit_mean_motion=s.orbit, lead=s.lead)
    (sources / "pc_fmu_data.h").write_text(header)
    for name, text in source_files().items():
        (sources / name).write_text(text)
    runtime = resources.files("postcapture.fmi") / "csrc"
    for name in (*SHARED_SOURCES, version.wrapper, version.wrapper_common):
        (sources / name).write_text((runtime / name).read_text())
    c_code = Path(fmpy.__file__).parent / "c-code"
    for name in version.headers:
        shutil.copy(c_code / name, sources / name)
    return interface, sum(p.stat().st_size for p in sources.glob("*.[ch]"))


def _compile(root: Path, build: Path, ident: str, out_path: Path, version) -> float:
    from postcapture.fmi.export.compiler import compile_library

    return compile_library(root / "sources", build, root / "binaries" / version.binary_folder() / (ident + ".so"),
                           fmu=str(out_path))


def _write_description(root: Path, scenario: Scenario, interface, plant, guid: str, s: _Settings, version) -> Mapping:
    """modelDescription.xml (and FMI 3.0's build description) and the embedded mapping; returns the mapping."""
    from postcapture._version import __version__
    from postcapture.fmi.export.model_description import DescriptionInfo, write_model_description
    from postcapture.fmi.export.model_description3 import write_build_description, write_model_description3
    from postcapture.fmi.export.structure import dependencies

    sources = tuple(sorted(p.name for p in (root / "sources").glob("*.c")))
    info = DescriptionInfo(
        model_name=f"{scenario.name} ({s.variant})",
        model_identifier=s.ident,
        guid=guid,
        description=scenario.description or f"postcapture plant of scenario {scenario.name}",
        generation_tool=f"postcapture {__version__} (compiled plant core)",
        directional_derivatives=s.directional,
        source_files=sources,
        stop_time=scenario.simulation.duration,
        step=scenario.simulation.sample_period,
        integrator=s.integrator,
        variant=s.variant,
        scenario=scenario.name,
        internal_step=s.step,
    )
    deps = dependencies(interface, plant, orbit=s.orbit > 0.0)
    if version.number == 3:
        text = write_model_description3(interface, info, deps)
        (root / "sources" / "buildDescription.xml").write_text(write_build_description(s.ident, list(sources)))
    else:
        text = write_model_description(interface, info, deps)
    (root / "modelDescription.xml").write_text(text)
    mapping = _mapping(plant, interface, s.ident, guid, s.integrator, s.step)
    (root / "resources").mkdir(exist_ok=True)
    (root / MAPPING_RESOURCE).write_text(mapping.to_toml())
    return mapping


def _mapping(plant, interface, ident: str, guid: str, integrator: str, step: float) -> Mapping:
    """The mapping of an exported plant: the state layout, the sensors' entries, the parameter inputs (the
    target's mass is ``target.m`` plus its panels') and the Jacobian outputs."""
    q_names = interface.names("x")[: plant.nq]
    jac = None
    if interface.step_jacobian:
        jac = JacobianOutputs(request="jacobian_request", F="F[{i},{j}]", H="H[{i},{j}]", G="G[{i},{j}]",
                              Hp="Hp[{i},{j}]", valid="jacobian_valid")
    return Mapping(
        state=tuple(interface.names("x")),
        correction=tuple(interface.names("xc")),
        reset="reset",
        kinematics="free_flyer",
        attitude=("q[7]", "q[4]", "q[5]", "q[6]"),
        rate=("v[4]", "v[5]", "v[6]"),
        accel=("accel_B_x", "accel_B_y", "accel_B_z"),
        joint_accel=tuple(f"arm_ddq_{i + 1}" for i in range(plant.n_arm)),
        velocity=("v[1]", "v[2]", "v[3]"),
        arm=tuple(q_names[int(k) + 1] for k in plant.arm_v),
        accelerometer_position=plant.accelerometer_position,
        parameters=tuple(interface.names("p")),
        mass_offset=plant.target_panel_mass if plant.has_target else None,
        jacobians=jac,
        info={"model_identifier": ident, "guid": guid, "integrator": integrator, "step": step},
    )
