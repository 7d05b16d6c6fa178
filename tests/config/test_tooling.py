"""Scenario tooling (issue 18): show, new, validate, the field reference."""

import json
import subprocess
import sys
from pathlib import Path

from postcapture.cli import main
from postcapture.config import load_scenario
from postcapture.config.reference import field_rows, reference_markdown

ROOT = Path(__file__).resolve().parents[2]


def test_new_then_validate_round_trips(tmp_path, capsys):
    out = tmp_path / "my_target.toml"
    assert main(["scenario", "new", "--like", "envisat", "-o", str(out)]) == 0
    assert main(["scenario", "validate", str(out)]) == 0
    assert "valid scenario 'my_target'" in capsys.readouterr().out
    mine, builtin = load_scenario(out), load_scenario("envisat")
    assert mine.name == "my_target" and mine.model_dump(exclude={"name"}) == builtin.model_dump(exclude={"name"})
    assert "# ESA CDF e.Deorbit figures" in out.read_text()  # the sources come along
    assert main(["scenario", "new", "--like", "envisat", "-o", str(out)]) == 1  # never overwritten


def test_validate_lists_every_problem_with_its_path_and_counts_them(tmp_path, capsys):
    out = tmp_path / "bad.toml"
    main(["scenario", "new", "-o", str(out)])
    text = out.read_text().replace("mass = 7827.9", "mas = 3000.0").replace('kind = "chirp"', 'kind = "chrip"')
    out.write_text(text)
    capsys.readouterr()
    code = main(["scenario", "validate", str(out), "--json"])
    doc = json.loads(capsys.readouterr().out)
    paths = sorted(p["path"] for p in doc["problems"])
    assert code == len(doc["problems"]) == 3 and not doc["valid"]
    assert paths == ["excitation[3]", "target.mas", "target.mass"], paths
    assert any("did you mean 'chirp'" in p["found"] for p in doc["problems"])


def test_show_prints_the_builtin_text():
    exe = str(Path(sys.executable).parent / "postcapture")
    done = subprocess.run([exe, "scenario", "show", "small_derelict"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and done.stdout.startswith("# A small derelict")


def test_the_reference_page_is_the_schema():
    page = (ROOT / "docs" / "scenario-reference.md").read_text()
    assert page == reference_markdown(), "docs/scenario-reference.md is stale: `postcapture scenario reference > ...`"


def test_every_number_has_a_unit_and_bounds():
    """A field added later gets its unit and bounds on the page by declaring them once (quantity(...))."""
    rows = {r.path: r for r in field_rows()}
    assert rows["target.panels[].length"].unit == "m" and "<= 1000" in rows["target.panels[].length"].bounds
    assert rows["uncertainty.gyro_bias"].unit == "rad/s" and "draws within +-0.01" in rows["uncertainty.gyro_bias"].bounds
    missing = [r.path for r in rows.values() if r.kind.startswith("number") and not (r.unit or "uncertainty." in r.path)]
    assert not missing, missing
