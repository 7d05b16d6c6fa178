"""A one-page report per run and per campaign (Markdown, written beside the results as ``report.md``).

It holds what a reviewer needs on one page: what was run and by what (provenance: version, commit,
command line, time), the table the command printed, the consistency verdicts, every metric of every case
(whatever metrics the estimation side adds appear as rows, since they are read from the summary), and
the figures. Markdown renders on any code host and converts to HTML or PDF (pandoc) for a review.
"""

from __future__ import annotations

import math

__all__ = ["run_report", "campaign_report", "verdict", "metrics_table"]


def _num(value) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def verdict(value, band) -> str:
    """Where a NEES average lies against its 95 % band: ``consistent``, ``overconfident`` (above) or
    ``conservative`` (below); ``-`` without a value."""
    if value is None or band is None or not all(math.isfinite(b) for b in band):
        return "-"
    lo, hi = band
    if value > hi:
        return f"overconfident ({value:.3g} above the band [{lo:.3g}, {hi:.3g}])"
    if value < lo:
        return f"conservative ({value:.3g} below the band [{lo:.3g}, {hi:.3g}])"
    return f"consistent ({value:.3g} in [{lo:.3g}, {hi:.3g}])"


def metrics_table(cases: dict) -> list[str]:
    """Every scalar metric of every case, one row per metric (Markdown); lists and tables are left out."""
    names = list(cases)
    keys: list[str] = []
    for metrics in cases.values():
        keys += [k for k, v in metrics.items() if not isinstance(v, (list, dict, tuple)) and k not in keys]
    lines = ["| metric | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for k in keys:
        lines.append(f"| `{k}` | " + " | ".join(_num(cases[n].get(k)) for n in names) + " |")
    return lines


def _provenance(prov: dict) -> list[str]:
    return [
        "| | |", "|---|---|",
        f"| package | postcapture {prov.get('postcapture_version', '?')} |",
        f"| source commit | `{prov.get('source_commit') or 'unknown (not a git checkout)'}` |",
        f"| command | `{prov.get('command_line', '?')}` |",
        f"| created | {prov.get('date_created', '?')} (UTC) |",
        f"| Python | {prov.get('python', '?')} |",
    ]


def _figures(names: list[str]) -> list[str]:
    out = []
    for name in names:
        stem = name.rsplit(".", 1)[0].replace("_", " ")
        out += [f"![{stem}]({name})" if not name.endswith(".pdf") else f"- [{stem}]({name})", ""]
    return out


def _truth_line(summary: dict) -> str:
    truth = summary.get("truth") or {}
    source = truth.get("source", "nominal")
    source = "the nominal scenario (the filters' parameters, on the truth's own integrator and step)" if source == "nominal" else source
    segments = truth.get("panel_segments")
    return f"Truth: {source}" + (f", panels in {', '.join(map(str, segments))} segments" if segments else "")


def _percent(value) -> str:
    return "-" if value is None else f"{100.0 * value:.1f} %"


def _kg(value) -> str:
    return "-" if value is None else f"{value:.1f}"


def run_report(summary: dict, table: str, figures: list[str]) -> str:
    """The main job's report (Markdown) from its summary (with ``"provenance"``), its table and figure files."""
    s = summary
    lines = [f"# Main job: scenario {s.get('scenario')}, {s.get('profile')} profile, seed {s.get('seed')}", "",
             f"{s.get('duration_s', 0):g} s, plant {s.get('plant', 'native')}. {_truth_line(s)}; true mass "
             f"{_kg(s.get('true_mass_kg'))} kg, the filters start at {_kg(s.get('initial_mass_kg'))} kg.", "",
             "## Provenance", "", *_provenance(s.get("provenance") or {}), "",
             "## Consistency", "",
             "| case | final mass error inside its 3σ | share of the run with the attitude inside 3σ | attitude NEES "
             "(3 expected) | faults detected | model inconsistent | diverged |",
             "|---|---|---|---|---|---|---|"]
    for name, m in s.get("cases", {}).items():
        err, sig = m.get("mass_error_kg"), m.get("mass_sigma_kg")
        inside = "-" if err is None or sig is None else ("yes" if abs(err) <= 3 * sig else "**no**")
        detections = "; ".join(d["text"] for d in m.get("detections") or ()) or "none"
        flags = "; ".join(f["text"] for f in m.get("model_inconsistent") or ()) or "no"
        lines.append(f"| {name} | {inside} | {_percent(m.get('attitude_inside_3sigma_fraction'))} | "
                     f"{_num(m.get('nees_mean'))} | {detections} | {flags} | "
                     f"{'no' if m.get('success', True) else '**' + (m.get('message') or 'yes') + '**'} |")
    lines += ["", "## Table", "", "```", table, "```", "", "## Every metric", "", *metrics_table(s.get("cases", {})),
              "", "## Figures", "", *_figures(figures)]
    return "\n".join(lines).rstrip() + "\n"


def campaign_report(summary: dict, table: str, figures: list[str]) -> str:
    """A campaign's report (Markdown) from its summary (with ``"provenance"``), its table and figure files."""
    s = summary
    kind = "dispersed truths drawn from the priors" if s.get("dispersed") else "one truth"
    lines = [f"# Campaign: scenario {s.get('scenario')}, {s.get('profile')} profile, {s.get('runs')} runs", "",
             f"{kind}; seeds ({s.get('seed')}, r).", "",
             "## Provenance", "", *_provenance(s.get("provenance") or {}), "",
             "## Consistency (NEES averaged over the runs and over time, against its 95 % band)", "",
             "| case | mass NEES | attitude NEES | runs inside their 3σ | diverged runs |", "|---|---|---|---|---|"]
    for name, c in s.get("cases", {}).items():
        lines.append(f"| {name} | {verdict(c.get('nees_mean'), c.get('nees_band'))} | "
                     f"{verdict(c.get('attitude_nees_mean'), c.get('attitude_nees_band'))} | "
                     f"{_percent(c.get('inside_3sigma_fraction'))} | {_num(c.get('diverged_runs'))} |")
    lines += ["", "## Table", "", "```", table, "```", "", "## Every metric", "", *metrics_table(s.get("cases", {})),
              "", "## Figures", "", *_figures(figures)]
    return "\n".join(lines).rstrip() + "\n"
