"""The main job's terminal table: two compact tables (mass, attitude) and notes, within 80 columns.

Values that came from the user (sensor noise) are printed in the unit they were most likely given in:
the one, among a quantity's usual units, in which the value is shortest to write (0.01 rad rather
than 2062.65 arcsec; 2 arcsec rather than 9.69627e-06 rad).
"""

from __future__ import annotations

import math
import textwrap

import numpy as np

from postcapture.core.units import ARCSEC, DEG_PER_SQRT_HOUR, MICRO_G

__all__ = ["WIDTH", "results_table", "in_given_unit", "wrap"]

WIDTH = 80
"""Terminal width every line of the table fits in."""


def _digits(x: float) -> int:
    """Significant digits needed to write ``x`` to 1e-9 relative (7 when it takes more than 6)."""
    if x == 0 or not math.isfinite(x):
        return 1
    for d in range(1, 7):
        if abs(float(f"{x:.{d}g}") - x) <= 1e-9 * abs(x):
            return d
    return 7


def in_given_unit(value: float, units: list[tuple[str, float]]) -> str:
    """``value`` (SI) written in the unit, among ``units``, that needs the fewest digits.

    Parameters
    ----------
    value : float
        The value in SI units.
    units : list of (str, float)
        Candidate units and their SI factor, in order of preference for ties.

    Returns
    -------
    str
        For example ``"0.01 rad"``.

    Examples
    --------
    >>> in_given_unit(0.01, [("rad", 1.0), ("arcsec", ARCSEC)])
    '0.01 rad'
    >>> in_given_unit(2 * ARCSEC, [("rad", 1.0), ("arcsec", ARCSEC)])
    '2 arcsec'
    """
    best = min(units, key=lambda u: _digits(value / u[1]))
    return f"{_number(value / best[1], min(_digits(value / best[1]), 3))} {best[0]}"


def _number(x: float, digits: int) -> str:
    """``x`` to ``digits`` significant digits: positional between 1e-4 and 1e6 (10, not 1e+01)."""
    if x != 0 and 1e-4 <= abs(x) < 1e6:
        return np.format_float_positional(x, precision=digits, unique=True, fractional=False, trim="-")
    return f"{x:.{digits}g}"


def wrap(text: str, *, indent: str = "", width: int = WIDTH) -> list[str]:
    """Lines of ``text`` within ``width`` columns; continuation lines indented two more spaces."""
    return textwrap.wrap(text, width=width, initial_indent=indent, subsequent_indent=indent + "  ",
                         break_on_hyphens=False) or [indent]


def _fmt(value, spec: str, none: str = "never") -> str:
    if value is None:
        return none
    if isinstance(value, float) and not math.isfinite(value):
        return "-"
    return format(value, spec)


def _rows(names, header: list[tuple[str, str, int]], cells: dict[str, list[str]], width: int) -> list[str]:
    """A table: a name column then right-aligned columns; a name too long for its row gets its own line."""
    rest = sum(w for _, _, w in header)
    name_w = max([4] + [len(n) for n in names])
    name_w = min(name_w, width - rest - 1)
    lines = [f"{'case':<{name_w}}" + "".join(f"{h:>{w}}" for h, _, w in header),
             f"{'':<{name_w}}" + "".join(f"{u:>{w}}" for _, u, w in header)]
    for n in names:
        values = "".join(f"{c:>{w}}" for c, (_, _, w) in zip(cells[n], header))
        if len(n) > name_w:
            lines.append(n)
            lines.append(" " * name_w + values)
        else:
            lines.append(f"{n:<{name_w}}{values}")
    return lines


def _noise(n: dict) -> str:
    angle = [("rad", 1.0), ("arcsec", ARCSEC), ("deg", math.pi / 180.0)]
    rate = float(n["rate_hz"])
    cross = in_given_unit(n["star_tracker_cross_arcsec"] * ARCSEC, angle)
    roll = in_given_unit(n["star_tracker_roll_arcsec"] * ARCSEC, angle)
    star = cross if cross == roll else f"{cross} cross-boresight, {roll} roll"
    arw = in_given_unit(n["gyro_arw_rad_sqrt_s"], [("rad/sqrt(s)", 1.0), ("deg/sqrt(h)", DEG_PER_SQRT_HOUR)])
    acc = in_given_unit(n["accelerometer_m_s2"], [("m/s^2", 1.0),
                                                  ("micro-g/sqrt(Hz)", MICRO_G * math.sqrt(rate))])
    bias = n["accelerometer_bias_m_s2"]
    bias_text = f", bias {in_given_unit(bias, [('m/s^2', 1.0), ('micro-g', MICRO_G)])}" if bias else ""
    joints = in_given_unit(n["encoder_rad"], [("rad", 1.0), ("arcsec", ARCSEC)])
    return (f"sensor noise (1 sigma), all at {rate:g} Hz: star tracker {star}; gyro angle random walk {arw}; "
            f"accelerometer velocity random walk {acc}{bias_text}; joint encoders {joints}")


def results_table(summary: dict, *, width: int = WIDTH) -> str:
    """The main job's tables and notes from its JSON summary, every line within ``width`` columns.

    Parameters
    ----------
    summary : dict
        ``MainJobResult.summary()``.
    width : int, optional
        Columns (default 80).

    Returns
    -------
    str
    """
    cases = summary["cases"]
    names = list(cases)
    dm = summary["initial_mass_kg"] - summary["true_mass_kg"]
    plant = summary.get("plant", "native")
    lines = wrap(f"scenario {summary['scenario']}, {summary['profile']} profile, seed {summary.get('seed', '?')}, "
                 f"{plant} plant, {summary['duration_s']:g} s", width=width)
    lines += wrap(f"true mass {summary['true_mass_kg']:.1f} kg; the filters start at "
                  f"{summary['initial_mass_kg']:.1f} kg ({dm:+.4g} kg)", width=width)
    lines.append("")
    mass_header = [("error", "(kg)", 10), ("3 sigma", "(kg)", 10), ("within 1 %", "from (s)", 12),
                   ("within 0.1 %", "from (s)", 14), ("wall", "(s)", 8)]
    mass_cells = {}
    for n, m in cases.items():
        three = None if m["mass_sigma_kg"] is None else 3 * m["mass_sigma_kg"]
        # a diverged filter's sigma says nothing (a re-initialised reference filter's fell to 1e-4 kg)
        three_cell = _fmt(three, ".3g", "-") if m.get("success", True) else "diverged"
        mass_cells[n] = [_fmt(m["mass_error_kg"], "+.2f", "-"), three_cell,
                         _fmt(m["settle_1pct_s"], ".1f"), _fmt(m["settle_01pct_s"], ".1f"), _fmt(m["wall_s"], ".1f", "-")]
    lines.append("Target mass at the end of the run")
    lines += _rows(names, mass_header, mass_cells, width)
    lines.append("")
    att_header = [("RMS", "(arcsec)", 10), ("steady", "(arcsec)", 10), ("in 3 sigma", "", 12),
                  ("NEES", "(3)", 10), ("NIS", "(3)", 8)]
    att_cells = {}
    for n, m in cases.items():
        att_cells[n] = [_fmt(m["attitude_rms_arcsec"], ".3g", "-"), _fmt(m["attitude_rms_steady_arcsec"], ".3g", "-"),
                        _fmt(m["attitude_inside_3sigma_fraction"], ".1%", "-"), _fmt(m["nees_mean"], ".3g", "-"),
                        _fmt(m["nis_mean"], ".2f", "-")]
    lines.append("Attitude (steady: second half of the run; NEES, NIS: means, 3 expected)")
    lines += _rows(names, att_header, att_cells, width)
    notes = []
    for n, m in cases.items():
        if not m.get("success", True):
            notes += wrap(f"{n}: {m.get('message') or 'diverged'}", indent="  ", width=width)
    crlb = summary.get("crlb_mass_kg")
    if crlb:
        params = summary.get("crlb_parameters_only_mass_kg") or {}
        known = summary.get("crlb_known_model_mass_kg") or {}
        text = (f"Cramer-Rao bound on the mass (1 sigma, every sensor): {crlb['all_sensors']:.3g} kg with the "
                "declared uncertain parameters, the biases and the declared model error unknown")
        if params.get("all_sensors") is not None and params["all_sensors"] != crlb["all_sensors"]:
            text += f"; {params['all_sensors']:.3g} kg without the model error"
        if known.get("all_sensors") is not None:
            text += (f"; {known['all_sensors']:.3g} kg for a known model ({known['accelerations_only']:.3g} kg from "
                     "the accelerations alone, what the reference's mass filter sees)")
        notes += wrap(text, indent="  ", width=width)
    far = summary.get("farrenkopf") or {}
    for n, v in far.items():
        if not isinstance(v, dict) or "steady" not in v:
            continue
        if v["steady"]:
            ratios = ", ".join(f"{r:.2f}" for r in v["ratio"])
            notes += wrap(f"{n}: steady attitude error / Farrenkopf's bound per star-tracker axis "
                          f"(cross, cross, boresight), last quarter of the run: {ratios}", indent="  ", width=width)
        else:
            own = ", ".join(f"{r:.2f}" for r in v["own_sigma_over_bound"])
            err = ", ".join(f"{r:.2f}" for r in v["error_over_own_sigma"])
            notes += wrap(f"{n}: not yet in steady state at the end of the run (too short for Farrenkopf's "
                          f"bound): its own sigma is {own} times the bound per star-tracker axis (cross, cross, "
                          f"boresight), its error {err} times its own sigma", indent="  ", width=width)
    for n, m in cases.items():
        for d in m.get("detections") or ():
            notes += wrap(f"{n}: {d['text']}", indent="  ", width=width)
        for f in m.get("model_inconsistent") or ():
            notes += wrap(f"{n}: {f['text']} (flagged at {f['time_s']:.1f} s)", indent="  ", width=width)
    if summary.get("noise"):
        notes += wrap(_noise(summary["noise"]), indent="  ", width=width)
    if notes:
        lines += ["", "Notes"] + notes
    lines.append("")
    lines += wrap(f"wall time {summary['wall_s']:.1f} s (truth {summary['truth_wall_s']:.1f} s)", width=width)
    return "\n".join(lines)
