"""Shared figure conventions: one fixed colour and line style per estimation case, titles, legends.

Every figure of the main job and of the campaigns draws a case with :func:`case_style` (or, for a set
of cases drawn together, :func:`case_styles`), so that a case keeps its colour and line style from
one figure to the next and from one run to the next, whatever the plotting order.

The named cases use the Okabe-Ito colour-blind-safe palette: a blue family for the EKF dual schemes,
an orange family for the MEKF dual schemes, green for the joint EKF; flexible filter models darker
than stiff ones. Dual schemes that share a mass filter draw the same mass curve, so the MEKF cases
are dashed and drawn above the EKF cases: both stay visible where they coincide.

A case name that is not in :data:`CASE_STYLES` gets a style from a hash of its name (SHA-256, not
Python's salted ``hash``) among colour and line-style pairs that no named case uses: the same name
gets the same style in every run. :func:`case_styles` also keeps the styles of a set of cases
distinct from each other.

Examples
--------
>>> case_style("ekf_flexible").color
'#0072B2'
>>> case_style("my_new_case") == case_style("my_new_case")
True
>>> styles = case_styles(["ekf_flexible", "tuned_a", "tuned_b"])
>>> len({(s.color, s.linestyle) for s in styles.values()})
3
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from matplotlib.figure import Figure

__all__ = [
    "CaseStyle",
    "CASE_STYLES",
    "TRUTH_STYLE",
    "BAND_ALPHA",
    "DPI",
    "MODEL_ORDER",
    "MODEL_TITLES",
    "case_style",
    "case_styles",
    "run_subtitle",
    "new_figure",
    "legend_outside",
    "panel_title",
    "mark_divergence",
    "band_edges",
    "BAND_EDGE",
    "artist_gid",
]


@dataclass(frozen=True)
class CaseStyle:
    """How one case is drawn.

    Parameters
    ----------
    color : str
        Hex colour.
    linestyle : str or tuple
        Matplotlib line style.
    linewidth : float
        Line width (points).
    zorder : float
        Drawing order: larger is drawn on top.
    """

    color: str
    linestyle: str | tuple = "-"
    linewidth: float = 1.6
    zorder: float = 3.0

    def line(self) -> dict:
        """Keyword arguments for ``Axes.plot``."""
        return {"color": self.color, "linestyle": self.linestyle, "linewidth": self.linewidth, "zorder": self.zorder}


_DASHED = (0, (5.0, 2.5))
_DOTTED = (0, (1.2, 1.8))
_DASHDOT = (0, (6.0, 2.0, 1.5, 2.0))

CASE_STYLES: dict[str, CaseStyle] = {
    "ekf_flexible": CaseStyle("#0072B2", "-", 2.0, 3.0),
    "mekf_flexible": CaseStyle("#D55E00", _DASHED, 1.5, 3.2),
    "dual": CaseStyle("#009E73", "-", 2.2, 3.6),
    "joint": CaseStyle("#332288", (0, (4.0, 3.0)), 1.4, 3.8),  # indigo dashes, drawn over dual's green
    "ekf_stiff": CaseStyle("#56B4E9", "-", 2.0, 3.0),
    "mekf_stiff": CaseStyle("#E69F00", _DASHED, 1.5, 3.2),
    "ekf_flexible_partial": CaseStyle("#CC79A7", _DASHDOT, 1.6, 3.1),
    "mekf_flexible_partial": CaseStyle("#882255", _DOTTED, 1.8, 3.3),
}
"""The fixed styles of the named cases. Add new names here to choose their style by hand."""

TRUTH_STYLE = {"color": "black", "linestyle": "-", "linewidth": 2.6, "zorder": 2.0, "label": "truth"}
"""The truth is a thick black line drawn under the estimates; no case is drawn in black."""

BAND_ALPHA = 0.14
"""Opacity of the faint fill between a 3-sigma band's edges (in the case's colour)."""

BAND_EDGE = {"linewidth": 0.8, "linestyle": (0, (1.0, 1.5)), "alpha": 0.9}
"""How a 3-sigma band's edges are drawn: thin dotted lines in the case's colour."""

DPI = 110
"""Resolution of the PNG files."""

MODEL_ORDER = ("flexible", "stiff", "rigid")
"""Order of the filter-model panels: (a) flexible, (b) stiff, (c) rigid; other models follow."""

MODEL_TITLES = {
    "flexible": "flexible filter model",
    "stiff": "stiff filter model (springs at 1e7 N m/rad)",
    "rigid": "rigid filter model",
}

# Paul Tol's muted palette (colour-blind safe), without the colours the named cases use.
_SPARE_COLOURS = ("#88CCEE", "#44AA99", "#117733", "#999933", "#DDCC77", "#CC6677", "#AA4499")
_SPARE_LINESTYLES = ("-", _DASHED, _DASHDOT, _DOTTED)


def _spare_slots() -> list[CaseStyle]:
    used = {(s.color, s.linestyle) for s in CASE_STYLES.values()}
    slots = []
    for ls in _SPARE_LINESTYLES:  # all colours solid first: the first extra cases stay easy to read
        for c in _SPARE_COLOURS:
            if (c, ls) not in used:
                slots.append(CaseStyle(c, ls, 1.6 if ls == "-" else 1.5, 3.5))
    return slots


_SLOTS = _spare_slots()


def _slot(name: str) -> int:
    digest = hashlib.sha256(name.encode("utf-8")).digest()
    return int.from_bytes(digest[:8], "big") % len(_SLOTS)


def case_style(name: str) -> CaseStyle:
    """The style of one case: fixed for the named cases, from a hash of the name otherwise.

    Parameters
    ----------
    name : str
        Case name.

    Returns
    -------
    CaseStyle
    """
    style = CASE_STYLES.get(name)
    return style if style is not None else _SLOTS[_slot(name)]


def case_styles(names: Iterable[str]) -> dict[str, CaseStyle]:
    """Styles of a set of cases drawn together, distinct from each other.

    Named cases keep their fixed style. Unnamed ones take their hashed slot, or, when another case of
    the set already holds it, the next free slot; the cases are resolved in sorted order, so the
    result depends only on the set of names, not on their order.

    Parameters
    ----------
    names : iterable of str
        Case names.

    Returns
    -------
    dict of str to CaseStyle
        In the order of ``names``.
    """
    names = list(dict.fromkeys(names))
    taken = {(s.color, s.linestyle) for n in names if (s := CASE_STYLES.get(n)) is not None}
    resolved = {n: CASE_STYLES[n] for n in names if n in CASE_STYLES}
    for name in sorted(n for n in names if n not in CASE_STYLES):
        i = _slot(name)
        for k in range(len(_SLOTS)):
            style = _SLOTS[(i + k) % len(_SLOTS)]
            if (style.color, style.linestyle) not in taken:
                break
        else:  # more unnamed cases than slots: share, still deterministic
            style = _SLOTS[i]
        taken.add((style.color, style.linestyle))
        resolved[name] = style
    return {n: resolved[n] for n in names}


def run_subtitle(*, scenario: str, profile: str, seed, duration_s: float | None = None, plant: str | None = None,
                 truth: str | None = None) -> str:
    """The line every figure title carries: scenario, sensor profile, seed (and duration, plant, the truth's source)."""
    parts = [f"scenario {scenario}", f"{profile} profile", f"seed {seed}"]
    if duration_s is not None:
        parts.append(f"{duration_s:g} s")
    if plant and plant != "native":
        parts.append(f"plant {plant}")
    if truth:
        parts.append(f"truth: {truth}")
    return ", ".join(parts)


def new_figure(nrows: int, ncols: int, *, time=None, width: float = 9.0, row_height: float = 3.0,
               sharey: bool | str = False):
    """A constrained-layout figure and its axes grid (2-D array), without pyplot's global state.

    With ``time`` (s), every axis spans the whole run, so a case that stops early is seen to stop.
    """
    fig = Figure(figsize=(width, row_height * nrows + 1.2), layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, sharex=True, sharey=sharey)
    for ax in axes.flat:
        ax.grid(alpha=0.3)
    if time is not None and len(time) > 1:
        axes[0, 0].set_xlim(float(time[0]), float(time[-1]))
    return fig, axes


def legend_outside(fig: Figure, *, ncols: int | None = None) -> None:
    """One legend for the whole figure, below the axes (never over the data); duplicates merged."""
    handles, labels = {}, []
    for ax in fig.axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in handles and not lab.startswith("_"):
                handles[lab] = h
                labels.append(lab)
    if labels:
        fig.legend([handles[lab] for lab in labels], labels, loc="outside lower center",
                   ncols=ncols or min(len(labels), 4), fontsize=8, frameon=False)


def panel_title(ax, index: int, text: str) -> None:
    """Title a panel ``(a) text``, ``(b) text``, ... as the reference's figures are."""
    ax.set_title(f"({chr(ord('a') + index)}) {text}", fontsize=10, loc="left")


def mark_divergence(ax, t_div: float, y, style: CaseStyle, name: str, *, text: bool = True) -> None:
    """Mark where a filter diverged: a dotted line and a cross in the case's colour, and a label.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    t_div : float
        Divergence time (s).
    y : float or None
        Last value drawn before the divergence (the cross goes there).
    style : CaseStyle
    name : str
        Case name.
    text : bool, optional
        Write "NAME diverged at T s" (once per column is enough).
    """
    ax.axvline(t_div, color=style.color, linestyle=":", linewidth=1.0, zorder=1.5)
    if y is not None and np.isfinite(y):
        ax.plot([t_div], [y], marker="X", markersize=9, color=style.color, markeredgecolor="black",
                linestyle="none", zorder=6, gid=artist_gid(name, "divergence"))
    if text:
        lo, hi = ax.get_xlim()
        right = t_div > lo + 0.6 * (hi - lo)  # late divergence: write to the left of the line
        ax.annotate(f"{name} diverged at {t_div:.1f} s", xy=(t_div, 0.97), xycoords=("data", "axes fraction"),
                    xytext=(-4 if right else 4, 0), textcoords="offset points", ha="right" if right else "left",
                    va="top", fontsize=8, color=style.color,
                    bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.8, "pad": 1.0})


def band_edges(ax, t, lower, upper, style: CaseStyle, case: str, *, label: str | None = None) -> None:
    """A case's band (``lower`` to ``upper``, e.g. +-3 sigma) drawn as its two edges in the case's colour, not as a
    fill: a fill wider than the axes is a flat tint whose edges never show. NaN samples leave gaps; the
    artists are tagged ``band``."""
    for k, edge in enumerate((lower, upper)):
        ax.plot(t, edge, color=style.color, zorder=style.zorder - 1.0, gid=artist_gid(case, "band"),
                label=label if k == 0 and label else "_nolegend_", **BAND_EDGE)


def artist_gid(case: str, kind: str) -> str:
    """The ``gid`` that tags an artist with its case and role (``line``, ``band``, ``divergence``)."""
    return f"case={case};{kind}"
