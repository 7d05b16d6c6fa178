"""The main job's figures as a reader gets them: every file there, one style per case, bands whole or absent.

A short main job (15 s, three cases on two filter models) is run once; its files are written as
``postcapture run`` writes them, and the figures are inspected through their artists: each line,
band and divergence mark carries ``gid = "case=<name>;<role>"``.
"""

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.collections import PolyCollection
from matplotlib.colors import to_hex
from matplotlib.lines import Line2D

from postcapture.studies.main_job import run_main_job
from postcapture.studies.results import to_dataset, write_results
from postcapture.core import rotations as rot
from postcapture.report.attitude import align_to, sign_continuous
from postcapture.report.figures import FIGURES, main_job_figures

CASES = ("ekf_flexible", "mekf_flexible", "ekf_stiff")
README = Path(__file__).resolve().parents[2] / "README.md"


@pytest.fixture(scope="module")
def job(envisat, tmp_path_factory):
    result = run_main_job(envisat, duration=15.0, cases=CASES, crlb=False, workers=2)
    out = tmp_path_factory.mktemp("main_job")
    paths = write_results(result, out)
    return result, out, paths


@pytest.fixture(scope="module")
def dataset(job):
    return to_dataset(job[0])


def _case_artists(fig):
    """(case, role, artist) for every tagged artist of a figure."""
    found = []
    for ax in fig.axes:
        for artist in list(ax.lines) + list(ax.collections):
            gid = artist.get_gid() or ""
            m = re.fullmatch(r"case=(\w+);(\w+)", gid)
            if m:
                found.append((m.group(1), m.group(2), artist))
    return found


def test_every_figure_is_written(job):
    _, out, paths = job
    expected = set()
    for spec in FIGURES:
        expected |= {spec.stem.format(case=c) for c in CASES} if "{case}" in spec.stem else {spec.stem}
    pngs = {p.stem for p in out.glob("*.png")}
    assert pngs == expected
    assert (out / "report.md").exists()
    for stem in expected:
        data = (out / f"{stem}.png").read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 20_000
        assert paths[stem] == out / f"{stem}.png"


def test_the_figures_redraw_from_the_results_file(job):
    _, out, _ = job
    with xr.open_dataset(out / "results.nc") as ds:
        figures = main_job_figures(ds.load())
    assert set(figures) == {p.stem for p in out.glob("*.png")}


def test_one_colour_and_line_style_per_case_across_figures(dataset):
    styles = {}
    for stem, fig in main_job_figures(dataset).items():
        for case, role, artist in _case_artists(fig):
            if role != "line":
                continue
            assert isinstance(artist, Line2D)
            style = (to_hex(artist.get_color()), artist.get_linestyle())
            styles.setdefault(case, {})[stem] = style
    assert set(styles) == set(CASES)
    for case, per_figure in styles.items():
        assert len(set(per_figure.values())) == 1, (case, per_figure)
        assert len(per_figure) >= 4  # attitude estimates, its own error figure, mass estimates, mass error
    distinct = {next(iter(per_figure.values())) for per_figure in styles.values()}
    assert len(distinct) == len(CASES)


def _span(t, finite):
    idx = np.nonzero(finite)[0]
    return t[idx[0]], t[idx[-1]], idx.size


@pytest.mark.parametrize("diverge", [False, True], ids=["as run", "ekf_stiff diverging at 8 s"])
def test_bands_cover_the_whole_span_of_their_case(dataset, diverge):
    ds = dataset.copy(deep=True)
    t = ds["time"].values
    if diverge:  # as a filter that diverges leaves it: NaN from the divergence on
        late = t >= 8.0
        for name in ("mass_est", "mass_sigma", "attitude_error", "attitude_sigma", "q_BN_est"):
            ds[name].loc[{"case": "ekf_stiff"}] = np.where(late, np.nan, ds[name].sel(case="ekf_stiff").values)
        ds["diverged_at"].loc[{"case": "ekf_stiff"}] = 8.0
    bands = 0
    for stem, fig in main_job_figures(ds).items():
        for case, role, artist in _case_artists(fig):
            if role != "band":
                continue
            bands += 1
            assert isinstance(artist, Line2D)  # a band is drawn as its edges, never as a fill (issue 18)
            x, y = np.asarray(artist.get_xdata()), np.asarray(artist.get_ydata())
            drawn = x[np.isfinite(y)]
            if stem.startswith("mass"):
                finite = np.isfinite(ds["mass_est"].sel(case=case).values) & np.isfinite(
                    ds["mass_sigma"].sel(case=case).values)
            else:
                finite = np.all(np.isfinite(ds["attitude_sigma"].sel(case=case).values), axis=0)
            start, stop, count = _span(t, finite)
            assert drawn.min() == pytest.approx(start) and drawn.max() == pytest.approx(stop), (stem, case)
            assert drawn.size == count, (stem, case)  # every sample of the span, no gap
    # two edges per attitude-error figure, per mass band of a distinct history, one 3σ line per attitude case
    assert bands >= 2 * (len(CASES) + 2)
    assert not [a for fig in main_job_figures(ds).values() for ax in fig.axes for a in ax.collections
                if isinstance(a, PolyCollection) and "band" in (a.get_gid() or "")]
    if diverge:
        marks = [(stem, case) for stem, fig in main_job_figures(ds).items()
                 for case, role, _ in _case_artists(fig) if role == "divergence"]
        assert ("mass_estimates", "ekf_stiff") in marks and ("attitude_error_ekf_stiff", "ekf_stiff") in marks


def test_titles_name_scenario_profile_seed_and_legends_sit_outside(dataset, job):
    result = job[0]
    for stem, fig in main_job_figures(dataset).items():
        title = fig._suptitle.get_text()
        assert "scenario envisat" in title and "reference profile" in title and f"seed {result.seed}" in title
        assert fig.legends, stem
        assert all(ax.get_legend() is None for ax in fig.axes), stem
    mass = main_job_figures(dataset)["mass_estimates"]
    panels = [ax.get_title(loc="left") for ax in mass.axes]
    assert panels[0].startswith("(a) flexible") and panels[1].startswith("(b) stiff")


def test_no_case_is_drawn_in_the_truths_colour():
    """Issue 18: joint was drawn black dotted, the truth's colour, and hidden under dual."""
    from postcapture.report.style import CASE_STYLES, TRUTH_STYLE

    colours = [to_hex(s.color) for s in CASE_STYLES.values()]
    assert to_hex(TRUTH_STYLE["color"]) not in colours
    assert len(set(zip(colours, map(str, (s.linestyle for s in CASE_STYLES.values()))))) == len(CASE_STYLES)
    assert CASE_STYLES["joint"].zorder > CASE_STYLES["dual"].zorder and CASE_STYLES["joint"].linestyle != "-"


def test_one_figure_per_distinct_attitude_history(dataset):
    """Issue 18: three of six attitude_error_*.png were identical. A case whose history equals an earlier one's
    gets no figure of its own; the first one's title names both."""
    ds = dataset.copy(deep=True)
    ds["attitude_error"].loc[{"case": "ekf_stiff"}] = ds["attitude_error"].sel(case="ekf_flexible").values
    figures = main_job_figures(ds)
    assert "attitude_error_ekf_stiff" not in figures and "attitude_error_ekf_flexible" in figures
    assert "ekf_flexible = ekf_stiff" in figures["attitude_error_ekf_flexible"]._suptitle.get_text()


def test_titles_name_the_truths_source(dataset):
    for stem, fig in main_job_figures(dataset).items():
        assert "truth: the nominal scenario" in fig._suptitle.get_text(), stem
    drawn = dataset.assign_attrs(truth_source="draw 7")
    assert "truth: draw 7" in main_job_figures(drawn)["mass_estimates"]._suptitle.get_text()


def test_figures_in_every_format(dataset, job, tmp_path):
    """``--format png|pdf|svg`` and ``--dpi``: the writer each figure goes through (one figure is enough)."""
    from postcapture.studies.results import _save_figure

    fig = main_job_figures(dataset)["mass_estimates"]
    for fmt, magic in (("pdf", b"%PDF"), ("svg", b"<?xml"), ("png", b"\x89PNG")):
        _save_figure(fig, fmt, None)(str(tmp_path / f"m.{fmt}"))
        assert (tmp_path / f"m.{fmt}").read_bytes().startswith(magic), fmt
    _save_figure(fig, "png", 40)(str(tmp_path / "small.png"))
    assert (tmp_path / "small.png").stat().st_size < (tmp_path / "m.png").stat().st_size  # fewer pixels than 110 dpi


def test_identical_histories_are_labelled(dataset):
    """The EKF and MEKF dual schemes share their mass filter: the legend says the second is the same."""
    labels = [t.get_text() for t in main_job_figures(dataset)["mass_estimates"].legends[0].get_texts()]
    assert "mekf_flexible (same as ekf_flexible)" in labels


def test_sign_continuous_attitude_has_no_hemisphere_jump():
    """A spin about z through a full turn: stored with w >= 0 it jumps to -q at half a turn; drawn, it must not."""
    angles = np.linspace(0.0, 2 * np.pi, 401)
    q = np.vstack([np.cos(angles / 2), np.zeros_like(angles), np.zeros_like(angles), np.sin(angles / 2)])
    stored = q * np.where(q[0] < 0, -1.0, 1.0)
    assert np.abs(np.diff(stored[3])).max() > 1.5
    smooth = sign_continuous(stored)
    assert np.abs(np.diff(smooth, axis=1)).max() < 0.02
    np.testing.assert_allclose(np.abs(np.einsum("ik,ik->k", smooth, q)), 1.0, atol=1e-12)  # same rotations
    noisy = rot.box_plus(stored, np.full((3, angles.size), 1e-3))
    aligned = align_to(noisy, smooth)
    assert np.all(np.einsum("ik,ik->k", aligned, smooth) > 0)


def test_unknown_case_styles_are_the_same_in_every_process():
    """A new case name's style comes from SHA-256 of the name, not from Python's salted hash()."""
    code = ("from postcapture.report.style import case_style, case_styles;"
            "print(case_style('dual_ekf_tuned').color, sorted((k, v.color) for k, v in "
            "case_styles(['a1', 'b2', 'c3']).items()))")
    outs = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                           env={**os.environ, "PYTHONHASHSEED": seed}).stdout for seed in ("1", "2")}
    assert len(outs) == 1


def test_readme_maps_every_figure_to_the_reference():
    text = README.read_text()
    for spec in FIGURES:
        assert f"`{spec.stem.replace('{case}', '<case>')}.png`" in text, spec.stem


def test_results_file_is_self_describing(job):
    """results.nc: every unit parses with UDUNITS (CF), and cases carry their filter model."""
    import cf_units

    _, out, _ = job
    with xr.open_dataset(out / "results.nc") as ds:
        units = {name: var.attrs["units"] for name, var in ds.variables.items() if "units" in var.attrs}
        for unit in units.values():
            cf_units.Unit(unit)
        assert cf_units.Unit(units["attitude_error"]).convert(np.pi / 648000, "arc_second") == pytest.approx(1.0)
        assert list(ds["filter_model"].values) == ["flexible", "flexible", "stiff"]
        assert np.all(np.isnan(ds["diverged_at"].values))
        assert ds.attrs["seed"] == job[0].seed and ds.attrs["profile"] == "reference"
