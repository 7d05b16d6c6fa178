"""One call from a panel description to a calibrated lumped chain: ``calibrate``.

Steps (the reference's section 3): the reference modes (the plate FEM of `postcapture.panels.fem`, an
OP2 file from the user's Nastran, or modes already computed); the chain of the multibody model with
the panel's length, width and mass; for each weight ``w`` the Gauss-Newton fit of the bending
stiffnesses (`postcapture.panels.identify`), the torsion spring from the first torsion frequency; the
sine-sweep validation of every fitted chain against the reference (`postcapture.panels.sweep`).

A panel file (TOML) gives the planform and the laminate in SI units::

    name = "my_wing"
    length = 6.0                      # m, root to tip
    width = 2.0                       # m
    [laminate]                        # as postcapture.panels.Laminate.from_dict
    cell_mass = 2.0                   # kg/m^2 on the top face
    [laminate.materials.cfrp]
    e1 = 181e9
    e2 = 10.3e9
    nu12 = 0.28
    g12 = 7.17e9
    g13 = 7.17e9
    g23 = 3.4e9
    rho = 1600.0
    [[laminate.plies]]                # bottom to top
    thickness = 0.000125
    angle_deg = 0.0
    material = "cfrp"
"""

from __future__ import annotations

import logging
import math
import os
import time
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np

from postcapture.core.errors import NastranError, PanelModelError, Problem
from postcapture.panels.builtin import BUILTIN_PANELS, builtin_panel
from postcapture.panels.calibration import CalibrationResult, CalibrationRun, run_label
from postcapture.panels.fem import assemble, solve_modes
from postcapture.panels.identify import ModalTarget, identify_stiffness, initial_stiffness, torsion_stiffness
from postcapture.panels.laminate import Laminate
from postcapture.panels.lumped import LumpedChain, chain_panel, lumped_modes
from postcapture.panels.mesh import PanelGeometry, panel_mesh
from postcapture.panels.modes import PanelModes
from postcapture.panels.sweep import (
    SweepSpec,
    spectral_peak,
    stiffness_damping,
    tip_response_chain,
    tip_response_fem,
)

__all__ = ["SWEEP_AMPLITUDE", "OP2_TOLERANCE", "load_panel_file", "compare_with_fem", "calibrate"]

logger = logging.getLogger(__name__)

SWEEP_AMPLITUDE = {"envisat": 1.0, "chaser": 0.01}
"""Tip force amplitude of the reference's sweeps (N); other panels get 1 N unless told."""

OP2_TOLERANCE = {"mass": 0.05, "frequency": 0.10, "modes": 3}
"""How far an OP2 reference may lie from the project's own FEM of the same panel and mesh before it is
refused (unless forced): the mass its mass-normalised shapes imply (relative, 5 %) and each of its
first ``modes`` frequencies (relative, 10 %). Independent solvers on this mesh agree to 0.02-0.45 %
(MYSTRAN, see the README's design notes); an OP2 of the wrong panel mass once gave stiffnesses 3.5 times too low."""


def compare_with_fem(modes: PanelModes, geometry: PanelGeometry, laminate: Laminate, *,
                     n_check: int = OP2_TOLERANCE["modes"]) -> dict:
    """Compare reference modes (an OP2's, on the `write_bdf` mesh) with the project's FEM of the panel.

    The mass: shapes normalised to the reference model's mass matrix ``M_ref`` have generalised masses
    ``phi^T M phi = m / m_ref`` under the project's ``M``; their median gives the reference's mass over
    ours. The frequencies: the first ``n_check`` of each, in ascending order.

    Returns
    -------
    dict
        ``mass_ratio`` (reference / ours), ``mass_kg`` (ours), ``frequencies_hz`` (reference) and
        ``fem_frequencies_hz`` (ours), ``frequency_ratios`` (reference / ours), each over the first
        ``n_check`` modes.
    """
    mesh = modes.mesh
    n = min(int(n_check), modes.n_modes)
    ours = solve_modes(geometry, laminate, n_length=mesh.n_length, n_width=mesh.n_width, n_modes=n)
    _, m = assemble(mesh, laminate)
    phi = modes.shapes.reshape(-1, modes.n_modes)[:, :n].astype(float)
    generalised = np.einsum("im,im->m", phi, m @ phi)
    ratio = 1.0 / float(np.median(generalised)) if np.all(generalised > 0) else float("inf")
    f_ref = np.asarray(modes.frequencies_hz[:n], dtype=float)
    f_ours = ours.frequencies_hz[:n]
    return {"mass_ratio": ratio, "mass_kg": laminate.areal_mass * geometry.area, "frequencies_hz": f_ref,
            "fem_frequencies_hz": f_ours, "frequency_ratios": f_ref / f_ours}


def _check_reference(modes: PanelModes, geometry, laminate, source: str, force: bool) -> str:
    """Refuse (or, forced, warn about) a reference too far from the project's FEM; a note for the report."""
    cmp = compare_with_fem(modes, geometry, laminate)
    off_mass = abs(cmp["mass_ratio"] - 1.0) > OP2_TOLERANCE["mass"]
    off_freq = bool(np.any(np.abs(cmp["frequency_ratios"] - 1.0) > OP2_TOLERANCE["frequency"]))
    note = (f"its shapes imply {cmp['mass_ratio']:.3g} times the panel's {cmp['mass_kg']:.4g} kg; its first "
            f"frequencies {', '.join(f'{f:.4g}' for f in cmp['frequencies_hz'])} Hz against the project's FEM "
            f"{', '.join(f'{f:.4g}' for f in cmp['fem_frequencies_hz'])} Hz")
    if not (off_mass or off_freq):
        return note
    what = " and ".join(w for w, off in (("mass", off_mass), ("frequencies", off_freq)) if off)
    message = (f"the OP2 reference differs from the project's own FEM of this panel in {what}, beyond the "
               f"tolerance (mass {OP2_TOLERANCE['mass']:.0%}, frequencies {OP2_TOLERANCE['frequency']:.0%}): {note}")
    if not force:
        raise NastranError(message + ". Check that the OP2 is of this panel (geometry, laminate, cell mass), in SI "
                           "units, with mass-normalised eigenvectors (EIGRL NORM=MASS); to calibrate against it "
                           "anyway, force it (--force-reference)", source)
    logger.warning("%s: %s. Used anyway, as --force-reference asks; the result records that it was forced",
                   source, message)
    return note + FORCED_NOTE


FORCED_NOTE = " (beyond the tolerance; forced)"
"""Ends the reference's description when it was used beyond the tolerance (``force_reference``)."""


def load_panel_file(path) -> tuple[PanelGeometry, Laminate]:
    """Read a panel description (planform and laminate) from a TOML file (format in the module text).

    Parameters
    ----------
    path : str or os.PathLike
        The TOML file.

    Returns
    -------
    geometry : PanelGeometry
        Length and width (m), named by ``name`` (default the file's stem).
    laminate : Laminate
        The section, plies bottom to top.

    Raises
    ------
    PanelModelError
        With every problem found: missing or unreadable file, invalid TOML, unknown keys, missing or
        non-positive dimensions, and every laminate problem of `Laminate.from_dict`.
    """
    source = os.fspath(path)
    try:
        data = tomllib.loads(Path(source).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise PanelModelError([Problem("panel", "envisat, chaser or an existing TOML file",
                                       repr(source))]) from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise PanelModelError([Problem("file", "a readable TOML file", str(exc))], source=source) from None
    problems = [Problem(k, "one of name, length, width, laminate", "an unknown key")
                for k in sorted(set(data) - {"name", "length", "width", "laminate"})]
    for key in ("length", "width"):
        v = data.get(key)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
            problems.append(Problem(key, "a finite length > 0 m", repr(v)))
    lam_spec = data.get("laminate")
    laminate = None
    if not isinstance(lam_spec, dict):
        problems.append(Problem("laminate", "a table with materials and plies", repr(lam_spec)))
    else:
        try:
            laminate = Laminate.from_dict(lam_spec, source=source)
        except PanelModelError as exc:
            problems += [Problem(f"laminate.{p.path}", p.expected, p.found) for p in exc.problems]
    name = str(data.get("name") or Path(source).stem)
    if problems:
        raise PanelModelError(problems, source=source)
    return PanelGeometry(float(data["length"]), float(data["width"]), name=name), laminate


def _resolve_panel(panel) -> tuple[PanelGeometry, Laminate, str]:
    if isinstance(panel, tuple) and len(panel) == 2 and isinstance(panel[0], PanelGeometry) \
            and isinstance(panel[1], Laminate):
        geometry, laminate = panel
        return geometry, laminate, geometry.name or laminate.name or "panel"
    if isinstance(panel, str) and panel in BUILTIN_PANELS:
        geometry, laminate = builtin_panel(panel)
        return geometry, laminate, panel
    if isinstance(panel, (str, os.PathLike)):
        geometry, laminate = load_panel_file(panel)
        return geometry, laminate, geometry.name
    raise PanelModelError([Problem("panel", "envisat, chaser, a TOML path or (PanelGeometry, Laminate)",
                                   type(panel).__name__)])


def _resolve_reference(reference, geometry, laminate, *, n_length, n_width,
                       n_modes, force: bool = False) -> tuple[PanelModes, str]:
    if isinstance(reference, PanelModes):
        g = reference.mesh.geometry
        if not (math.isclose(g.length, geometry.length) and math.isclose(g.width, geometry.width)):
            raise PanelModelError([Problem("reference",
                                           f"modes of a {geometry.length:g} m x {geometry.width:g} m panel",
                                           f"modes of a {g.length:g} m x {g.width:g} m one")])
        return reference, f"given modes ({reference.mesh.n_length} x {reference.mesh.n_width} mesh)"
    if isinstance(reference, str) and reference == "fem":
        modes = solve_modes(geometry, laminate, n_length=n_length, n_width=n_width, n_modes=n_modes)
        return modes, f"FEM (pyfe3d Quad4, {n_length} x {n_width} elements, {n_modes} modes)"
    if isinstance(reference, (str, os.PathLike)):
        from postcapture.panels.nastran import read_op2_modes

        op2 = read_op2_modes(reference)
        modes = op2.to_panel_modes(panel_mesh(geometry, n_length=n_length, n_width=n_width))
        note = _check_reference(modes, geometry, laminate, os.fspath(reference), force)
        return modes, f"OP2 {os.fspath(reference)} ({modes.n_modes} modes; {note})"
    raise PanelModelError([Problem("reference", "'fem', an OP2 path or PanelModes",
                                   type(reference).__name__)])


def _check_inputs(segments, weights, damping_ratio) -> tuple[float, ...]:
    problems = []
    if isinstance(segments, bool) or not isinstance(segments, (int, np.integer)) or not 1 <= segments <= 1000:
        problems.append(Problem("segments", "an integer in [1, 1000]", repr(segments)))
    try:
        ws = tuple(float(w) for w in weights)
    except (TypeError, ValueError):
        ws = ()
    if not ws or any(not (math.isfinite(w) and w > 0) for w in ws):
        problems.append(Problem("weights", "one or more finite weights > 0", repr(weights)))
    elif len({run_label(w) for w in ws}) != len(ws):
        problems.append(Problem("weights", "distinct weights", repr(weights)))
    if isinstance(damping_ratio, bool) or not isinstance(damping_ratio, (int, float)) \
            or not 0 < damping_ratio < 1:
        problems.append(Problem("damping_ratio", "a damping ratio in (0, 1)", repr(damping_ratio)))
    if problems:
        raise PanelModelError(problems)
    return ws


def calibrate(panel="envisat", *, segments: int = 5, weights=(1.0, 10.0, 0.1), reference="fem",
              n_bending: int = 3, damping_ratio: float = 0.01, sweep: SweepSpec | None = None,
              n_length: int = 60, n_width: int = 20, n_modes: int = 12, force_reference: bool = False,
              progress: Callable[[int, int, str], None] | None = None) -> CalibrationResult:
    """Calibrate the lumped chain of a panel against plate modes and validate it by a tip sine sweep.

    Parameters
    ----------
    panel : str, os.PathLike or tuple, optional
        ``"envisat"`` or ``"chaser"`` (`postcapture.panels.builtin`), a TOML panel file (module text),
        or ``(PanelGeometry, Laminate)``. Default ``"envisat"``.
    segments : int, optional
        Number of chain segments ``N``. Default 5 (the reference's).
    weights : sequence of float, optional
        Shape weights ``w`` of ``W(w)``, one run each. Default ``(1, 10, 0.1)`` (the reference's runs).
    reference : {"fem"}, os.PathLike or PanelModes, optional
        ``"fem"`` solves the plate FEM; a path reads a Nastran OP2 (mass-normalised eigenvectors of
        the ``n_length x n_width`` mesh of `postcapture.panels.nastran.write_bdf`); or modes at hand.
    n_bending : int, optional
        Reference bending modes fitted (at most N are used). Default 3.
    damping_ratio : float, optional
        Damping ratio at the first reference bending mode, as stiffness-proportional damping in
        both models for the sweep (-). Default 0.01.
    sweep : SweepSpec, optional
        Default `SweepSpec.for_modes` of the fitted reference frequencies, 100 s, 800 samples,
        amplitude `SWEEP_AMPLITUDE` (1 N, or 0.01 N for the chaser).
    n_length, n_width : int, optional
        FEM mesh (also the OP2's). Default 60 x 20.
    n_modes : int, optional
        Reference modes computed by the FEM (all superposed in the sweep). Default 12.
    force_reference : bool, optional
        Use an OP2 reference even when it lies beyond `OP2_TOLERANCE` of the project's own FEM of the
        panel (implied mass, first frequencies); by default such a reference is refused. Default False.
    progress : callable, optional
        ``progress(done, total, message) -> None`` after each stage.

    Returns
    -------
    CalibrationResult

    Raises
    ------
    PanelModelError
        For a bad panel, segment count, weight, damping ratio or reference, or a reference without a
        bending or torsion mode.
    NastranError
        If the OP2 file cannot be used, or lies beyond `OP2_TOLERANCE` of the project's FEM (unless
        ``force_reference``).
    """
    t0 = time.perf_counter()
    ws = _check_inputs(segments, weights, damping_ratio)
    geometry, laminate, name = _resolve_panel(panel)
    total = 2 + 2 * len(ws)
    done = 0

    def step(message: str) -> None:
        nonlocal done
        done += 1
        logger.info("[%d/%d] %s", done, total, message)
        if progress is not None:
            progress(done, total, message)

    modes, ref_text = _resolve_reference(reference, geometry, laminate, n_length=n_length, n_width=n_width,
                                         n_modes=n_modes, force=force_reference)
    step(f"reference modes: {ref_text}")
    target = ModalTarget.from_panel_modes(modes, segments, n_bending=n_bending)
    if not math.isfinite(target.torsion_hz):
        raise PanelModelError([Problem("reference", "a torsion mode among its modes (raise n_modes)",
                                       f"{modes.n_modes} modes, none of them torsion")])
    n_fit = min(target.n_modes, segments)
    mass = laminate.areal_mass * geometry.area
    k_start = initial_stiffness(target, mass / geometry.length)
    chain = LumpedChain(chain_panel(name, length=geometry.length, width=geometry.width, mass=mass,
                                    bending_stiffness=k_start, torsion_stiffness=1.0))
    k_tor = torsion_stiffness(chain, target.torsion_hz)
    f_ref = target.bending_hz[:n_fit]
    builtin = isinstance(panel, str) and panel in BUILTIN_PANELS
    spec = sweep or SweepSpec.for_modes(f_ref, amplitude=SWEEP_AMPLITUDE.get(panel, 1.0) if builtin else 1.0)
    beta = stiffness_damping(damping_ratio, f_ref[0])
    fem_tip = tip_response_fem(modes, spec, beta=beta)
    fem_peak, _ = spectral_peak(fem_tip, spec.sample_period, band=_band(spec, target.bending_hz))
    step(f"reference sweep: first peak {fem_peak:.5f} Hz")

    fine = np.linspace(0.0, geometry.length, 8 * max(segments, 8) + 1)
    fem_w, _ = modes.centreline(fine, modes.indices("bending")[:n_fit])
    runs = {}
    for w in ws:
        label = run_label(w)
        fit = identify_stiffness(chain, target, weight=w, k0=k_start)
        step(f"{label}: fit in {fit.iterations} iterations, cost {fit.cost:.3e}")
        fitted = chain.with_stiffness(fit.k, k_tor, beta)
        lm = lumped_modes(fitted)
        bend = lm.indices("bending")[fit.pairing]
        stations = geometry.length / segments * np.arange(segments + 1)
        joint_w, _ = lm.centreline(stations, bend)
        joint_w = joint_w / joint_w[-1]  # unit tip deflection, as fem_w
        tip = tip_response_chain(fitted, spec)
        band = _band(spec, lm.frequencies_hz[lm.indices("bending")])
        peak, _ = spectral_peak(tip, spec.sample_period, band=band)
        runs[label] = CalibrationRun(weight=w, k=fit.k, k_torsion=k_tor,
                                     frequencies_hz=lm.frequencies_hz[bend],
                                     torsion_hz=lm.frequency("torsion"), mac=fit.mac, peak_hz=peak, tip=tip,
                                     joint_w=joint_w, converged=fit.converged, iterations=fit.iterations,
                                     cost=fit.cost)
        step(f"{label}: first peak {peak:.5f} Hz (reference {fem_peak:.5f} Hz)")
    return CalibrationResult(
        name=name, length=geometry.length, width=geometry.width, mass=mass, segments=segments,
        reference=ref_text, forced_reference=FORCED_NOTE in ref_text,
        fem_hz=f_ref.copy(), fem_torsion_hz=target.torsion_hz, fem_peak_hz=fem_peak, fem_tip=fem_tip,
        damping_ratio=float(damping_ratio), beta=beta, sweep=spec, runs=runs, fem_stations=fine,
        fem_w=fem_w / fem_w[-1], elapsed_s=time.perf_counter() - t0)


def _band(spec: SweepSpec, bending_hz) -> tuple[float, float]:
    """Search band of a model's first resonance: from the sweep's start to between its first two modes."""
    f = np.asarray(bending_hz, dtype=float)
    upper = math.sqrt(f[0] * f[1]) if f.size > 1 else 2.0 * f[0]
    return spec.f_start, min(upper, spec.f_stop)
