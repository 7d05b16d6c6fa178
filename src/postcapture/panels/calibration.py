"""The result of a panel calibration: runs per weight, tables, JSON, a scenario TOML fragment, files.

`CalibrationResult` is what `postcapture.panels.calibrate.calibrate` returns. Its tables follow the
reference's tables 1-3 (first resonance peak per weight against the FEM's, fitted stiffnesses, modal
comparison); ``to_json`` gives the command line's ``--json`` document; ``toml_fragment`` a
``[[chaser.panels]]`` or ``[[target.panels]]`` entry a scenario can take; ``write`` puts them all in a
folder, with figures drawn by a caller-supplied function (``postcapture.report.panels`` has one), so
that this package does not depend on the report layer.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import tomli_w

from postcapture.core.errors import PanelModelError, Problem
from postcapture.io import ResultSet, safe_stem
from postcapture.panels.sweep import SweepSpec, amplitude_spectrum

__all__ = ["PLOT_ZERO_PAD", "run_label", "CalibrationRun", "CalibrationResult"]

logger = logging.getLogger(__name__)

PLOT_ZERO_PAD = 8
"""Zero-padding of the spectra drawn around the first peak: the record's continuous spectrum (-)."""


def run_label(weight: float) -> str:
    """Key of a run in the JSON and the tables: ``"w=0.1"`` for a shape weight of 0.1."""
    return f"w={weight:g}"


@dataclass(frozen=True)
class CalibrationRun:
    """One identification (one shape weight) and its sweep validation.

    Attributes
    ----------
    weight : float
        Shape weight ``w`` of ``W(w)`` (see `postcapture.panels.identify`) (-).
    k : ndarray, shape (N,)
        Fitted bending hinge stiffnesses, root to tip (N m/rad).
    k_torsion : float
        Torsion hinge stiffness from the first torsion frequency (N m/rad).
    frequencies_hz : ndarray, shape (n,)
        Chain bending frequencies paired with the reference's first ``n`` bending modes (Hz), from the
        simulated model's `postcapture.dynamics.modes.structural_modes`.
    torsion_hz : float
        Chain torsion frequency (Hz).
    mac : ndarray, shape (n,)
        MAC of the paired bending modes on the sampled shapes (-).
    peak_hz : float
        Interpolated first resonance peak of the chain's tip response to the sweep (Hz).
    tip : ndarray, shape (n_samples,)
        The chain's tip deflection (m).
    joint_w : ndarray, shape (N + 1, n)
        Paired bending shapes at the stations ``j L / N``, j = 0..N, unit tip deflection (-).
    converged : bool
        Whether Gauss-Newton converged.
    iterations : int
        Gauss-Newton iterations.
    cost : float
        Final weighted cost ``e^T W e`` (-).
    """

    weight: float
    k: np.ndarray
    k_torsion: float
    frequencies_hz: np.ndarray
    torsion_hz: float
    mac: np.ndarray
    peak_hz: float
    tip: np.ndarray
    joint_w: np.ndarray
    converged: bool
    iterations: int
    cost: float


@dataclass(frozen=True)
class CalibrationResult:
    """Calibration of a lumped panel chain against reference plate modes, for several weights.

    Attributes
    ----------
    name : str
        Panel name.
    length, width : float
        Panel size (m).
    mass : float
        Panel mass, laminate areal mass times area (kg).
    segments : int
        Number of chain segments ``N``.
    reference : str
        Where the reference modes came from (FEM mesh, OP2 file, ...).
    fem_hz : ndarray, shape (n,)
        The reference's first ``n`` bending frequencies, those fitted (Hz).
    fem_torsion_hz : float
        The reference's first torsion frequency (Hz).
    fem_peak_hz : float
        Interpolated first resonance peak of the reference's tip response (Hz).
    fem_tip : ndarray, shape (n_samples,)
        The reference's tip deflection under the sweep (m).
    damping_ratio : float
        Damping ratio at the first reference bending mode (-).
    beta : float
        The stiffness-proportional damping it implies, in both models (s).
    sweep : SweepSpec
        The tip sweep.
    runs : dict of str to CalibrationRun
        One run per weight, keyed by `run_label`, in the order given.
    fem_stations : ndarray, shape (n_fine,)
        Stations of ``fem_w`` (m).
    fem_w : ndarray, shape (n_fine, n)
        Reference bending shapes along the centreline, unit tip deflection (-).
    elapsed_s : float
        Wall time of the calibration (s).
    """

    name: str
    length: float
    width: float
    mass: float
    segments: int
    reference: str
    fem_hz: np.ndarray
    fem_torsion_hz: float
    fem_peak_hz: float
    fem_tip: np.ndarray
    damping_ratio: float
    beta: float
    sweep: SweepSpec
    runs: dict = field(default_factory=dict)
    fem_stations: np.ndarray = field(default_factory=lambda: np.zeros(0))
    fem_w: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    elapsed_s: float = float("nan")
    forced_reference: bool = False

    def __repr__(self) -> str:
        best = self.run()
        return (f"CalibrationResult(panel {self.name!r}, {self.segments} segments, {len(self.runs)} runs "
                f"({', '.join(self.runs)}); best {run_label(best.weight)}: first peak {best.peak_hz:.5g} Hz against "
                f"{self.fem_peak_hz:.5g} Hz{'; reference forced beyond its tolerance' if self.forced_reference else ''})")

    # ------------------------------------------------------------------ selection
    def run(self, label: str | None = None) -> CalibrationRun:
        """Return a run by label (``"w=0.1"``); default the best, whose first peak is nearest the FEM's.

        Raises
        ------
        PanelModelError
            If there is no run with that label.
        """
        if label is None:
            return min(self.runs.values(),
                       key=lambda r: (abs(r.peak_hz - self.fem_peak_hz), -float(np.min(r.mac))))
        if label not in self.runs:
            raise PanelModelError([Problem("run", f"one of {', '.join(self.runs)}", repr(label))])
        return self.runs[label]

    # ------------------------------------------------------------------ documents
    def to_dict(self) -> dict:
        """Return the ``--json`` document as plain data.

        Returns
        -------
        dict
            ``{"reference": ..., "forced_reference": ..., "fem_hz": [...], "runs": {"w=0.1": {"k": [...],
            "k_torsion": ..., "peak_hz": ..., "fem_peak_hz": ..., "mac": [...]}, ...}}``: what the reference
            was and whether it was used beyond its tolerance (``force_reference``), the fitted reference
            bending frequencies (Hz), and per run the stiffnesses (N m/rad), the first peaks (Hz) and the MAC (-).
        """
        return {
            "reference": self.reference,
            "forced_reference": bool(self.forced_reference),
            "fem_hz": [float(f) for f in self.fem_hz],
            "runs": {label: {"k": [float(k) for k in r.k], "k_torsion": float(r.k_torsion),
                             "peak_hz": float(r.peak_hz), "fem_peak_hz": float(self.fem_peak_hz),
                             "mac": [float(m) for m in r.mac]}
                     for label, r in self.runs.items()},
        }

    def to_json(self, *, indent: int | None = 2) -> str:
        """Return `to_dict` as JSON text (``indent`` spaces per level, None for one line)."""
        from postcapture.io import json_text

        return json_text(self.to_dict(), indent=indent)

    def tables(self) -> str:
        """Text tables in the manner of the reference's tables 1-3 (peaks, stiffnesses, modes)."""
        labels = list(self.runs)
        runs = [self.runs[k] for k in labels]
        n_b = self.fem_hz.size
        sw = self.sweep
        head = (f"Panel {self.name}: {self.length:g} m x {self.width:g} m, {self.mass:.1f} kg, "
                f"N = {self.segments} segments; reference: {self.reference}\n"
                f"Damping: beta = {self.beta:.4g} s (zeta = {self.damping_ratio:g} at the first bending "
                f"mode) in both; sweep {sw.f_start:.4g}-{sw.f_stop:.4g} Hz, {sw.amplitude:g} N, "
                f"{sw.duration:g} s, {sw.n_samples} samples")
        col = max(10, *(len(label) + 2 for label in labels))
        t1 = ["Table 1: first resonance peak of the tip displacement (interpolated)",
              f"{'':<12}" + "".join(f"{'lumped':>{col}}" for _ in runs) + f"{'FEM':>{col}}",
              f"{'weight':<12}" + "".join(f"{r.weight:>{col}g}" for r in runs) + f"{'-':>{col}}",
              f"{'peak [Hz]':<12}" + "".join(f"{r.peak_hz:>{col}.5f}" for r in runs)
              + f"{self.fem_peak_hz:>{col}.5f}",
              f"{'error [%]':<12}"
              + "".join(f"{100 * (r.peak_hz / self.fem_peak_hz - 1):>{col}.2f}" for r in runs)]
        t2 = ["Table 2: stiffnesses [N m/rad]", f"{'':<12}" + "".join(f"{label:>{col}}" for label in labels)]
        t2 += [f"{f'k_{i + 1}':<12}" + "".join(f"{r.k[i]:>{col}.5g}" for r in runs)
               for i in range(self.segments)]
        t2 += [f"{'k_tor':<12}" + "".join(f"{r.k_torsion:>{col}.5g}" for r in runs)]
        t3 = ["Table 3: bending frequencies [Hz] and MAC against the reference",
              f"{'mode':<12}{'reference':>{col}}" + "".join(f"{label:>{col}}{'MAC':>8}" for label in labels)]
        for i in range(n_b):
            t3.append(f"{f'bending {i + 1}':<12}{self.fem_hz[i]:>{col}.4f}"
                      + "".join(f"{r.frequencies_hz[i]:>{col}.4f}{r.mac[i]:>8.4f}" for r in runs))
        t3.append(f"{'torsion 1':<12}{self.fem_torsion_hz:>{col}.4f}"
                  + "".join(f"{r.torsion_hz:>{col}.4f}{'':>8}" for r in runs))
        t3.append(f"{'GN iter.':<12}{'':>{col}}" + "".join(
            f"{r.iterations:>{col}d}{'' if r.converged else ' (no)':>8}" for r in runs))
        return "\n\n".join([head, "\n".join(t1), "\n".join(t2), "\n".join(t3)]) + "\n"

    def toml_fragment(self, run: str | None = None, *, host: str | None = None,
                      name: str | None = None) -> str:
        """Return a scenario panel entry with the fitted stiffnesses, as TOML text.

        Parameters
        ----------
        run : str, optional
            Run label (``"w=0.1"``); default the best run (`run`).
        host : {"chaser", "target"}, optional
            Table ``[[<host>.panels]]``; default ``"target"`` for Envisat's wing, else ``"chaser"``.
        name : str, optional
            Panel name in the scenario; default the calibrated panel's.

        Returns
        -------
        str
            TOML text of one ``[[<host>.panels]]`` table that a scenario takes as it is: ``name``, ``length``,
            ``width``, ``mass``, ``segments``, ``bending_stiffness``, ``torsion_stiffness``, ``damping_beta``
            (the sweep's assumption, not identified) and ``mount`` (at the host's origin: move it to where
            the panel is attached), in SI units, with comments on its origin.

        Raises
        ------
        PanelModelError
            For an unknown run label or host.
        """
        r = self.run(run)
        label = run_label(r.weight)
        host = host or ("target" if self.name == "envisat" else "chaser")
        if host not in ("chaser", "target"):
            raise PanelModelError([Problem("host", "chaser or target", repr(host))])
        from postcapture.io import safe_stem

        panel_name = safe_stem(name or self.name)
        panel_name = panel_name if panel_name[:1].isalpha() else f"panel_{panel_name}"
        entry = {"name": panel_name[:64], "length": self.length, "width": self.width,
                 "mass": _round(self.mass), "segments": self.segments,
                 "bending_stiffness": [_round(k) for k in r.k], "torsion_stiffness": _round(r.k_torsion),
                 "damping_beta": _round(self.beta),
                 "mount": {"xyz": [0.0, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0]}}
        body = tomli_w.dumps({host: {"panels": [entry]}})
        notes = [f"# Lumped panel calibrated by postcapture: {self.name}, {self.segments} segments, {label}",
                 f"# reference: {self.reference}",
                 (f"# first resonance peak {r.peak_hz:.5f} Hz (reference {self.fem_peak_hz:.5f} Hz); "
                  f"MAC {' '.join(f'{m:.4f}' for m in r.mac)}"),
                 f"# damping_beta (s): zeta = {self.damping_ratio:g} at the first bending mode, the sweep's "
                 "assumption (not identified)",
                 "# mount: the pose of the panel root in the host frame (xyz m, rpy rad); at the host's origin "
                 "here: move it to where the panel is attached"]
        return "\n".join(notes) + "\n" + body

    # ------------------------------------------------------------------ plots and files
    def plot_data(self) -> dict:
        """Plain arrays for `postcapture.report.panels.calibration_figures`.

        Returns
        -------
        dict
            ``name``, ``segments``, ``reference``; ``spectra``: ``freqs`` (n_f,) (Hz), ``fem`` (n_f,) and
            ``lumped`` {label: (n_f,)} single-sided amplitudes (m), the same zero-padded
            `PLOT_ZERO_PAD` times as ``freqs_fine``, ``fem_fine``, ``lumped_fine``; ``fem_peak_hz``,
            ``peaks_hz``
            {label: Hz}, ``band`` (f_start, f_stop) (Hz); ``shapes``: ``fem_stations`` (n_fine,) (m),
            ``fem_w`` (n_fine, n), ``joint_stations`` (N + 1,) (m), ``lumped_w`` {label: (N + 1, n)}
            (unit tip deflection), ``fem_hz`` (n,), ``lumped_hz`` {label: (n,)}, ``mac`` {label: (n,)}.
        """
        dt = self.sweep.sample_period
        freqs, fem_amp = amplitude_spectrum(self.fem_tip, dt)
        fine, fem_fine = amplitude_spectrum(self.fem_tip, dt, zero_pad=PLOT_ZERO_PAD)
        return {
            "name": self.name, "segments": self.segments, "reference": self.reference,
            "spectra": {"freqs": freqs, "fem": fem_amp,
                        "lumped": {k: amplitude_spectrum(r.tip, dt)[1] for k, r in self.runs.items()},
                        "freqs_fine": fine, "fem_fine": fem_fine,
                        "lumped_fine": {k: amplitude_spectrum(r.tip, dt, zero_pad=PLOT_ZERO_PAD)[1]
                                        for k, r in self.runs.items()},
                        "fem_peak_hz": self.fem_peak_hz,
                        "peaks_hz": {k: r.peak_hz for k, r in self.runs.items()},
                        "band": (self.sweep.f_start, self.sweep.f_stop)},
            "shapes": {"fem_stations": self.fem_stations, "fem_w": self.fem_w,
                       "joint_stations": self.length / self.segments * np.arange(self.segments + 1),
                       "lumped_w": {k: r.joint_w for k, r in self.runs.items()}, "fem_hz": self.fem_hz,
                       "lumped_hz": {k: r.frequencies_hz for k, r in self.runs.items()},
                       "mac": {k: r.mac for k, r in self.runs.items()}},
        }

    def write(self, out_dir, *, run: str | None = None,
              figures: Callable[[Mapping], Mapping] | None = None) -> list[Path]:
        """Write the tables, the JSON, the TOML fragment and, optionally, figures, as one set.

        The folder is replaced as a whole (:class:`postcapture.io.ResultSet`): a failure leaves the
        previous set as it was; entries that are not calibration results are kept.

        Parameters
        ----------
        out_dir : str or os.PathLike
            Folder (created if missing).
        run : str, optional
            Run whose TOML fragment is written; default the best.
        figures : callable, optional
            ``figures(plot_data) -> {stem: matplotlib.figure.Figure}``, e.g.
            `postcapture.report.panels.calibration_figures`; each figure goes to ``<stem>.png``.

        Returns
        -------
        list of Path
            ``calibration.txt``, ``calibration.json``, ``<name>_panel.toml`` and the figures.
        """
        texts = {"calibration.txt": self.tables(), "calibration.json": self.to_json() + "\n",
                 f"{safe_stem(self.name)}_panel.toml": self.toml_fragment(run)}
        owned = ("calibration.txt", "calibration.json", "*_panel.toml", "sweep_spectra.png", "mode_shapes.png")
        with ResultSet(out_dir, owned=owned, kind="postcapture panel calibrate") as rs:
            paths = [rs.write(fname, lambda p, t=text: Path(p).write_text(t, encoding="utf-8"))
                     for fname, text in texts.items()]
            if figures is not None:
                for stem, fig in figures(self.plot_data()).items():
                    paths.append(rs.write(f"{safe_stem(stem)}.png", lambda p, f=fig: f.savefig(p, format="png", dpi=120)))
        logger.info("calibration of %s written to %s (%d files)", self.name, rs.folder, len(paths))
        return paths


def _round(x: float) -> float:
    """Six significant digits, enough for a stiffness or a mass in a scenario file."""
    return float(f"{float(x):.6g}")
