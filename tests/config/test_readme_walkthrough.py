"""The README's walk-through builds a 3 t target from the field reference alone (issue 18's acceptance)."""

import re
import subprocess
import sys
import tomllib
from pathlib import Path

from postcapture.config import load_scenario

README = Path(__file__).resolve().parents[2] / "README.md"


def test_the_walkthrough_target_loads_and_builds(tmp_path):
    text = README.read_text()
    section = text[text.index("**Walk-through: a 3 t target**"):text.index("## Panel calibration")]
    block = re.search(r"```toml\n(.*?)```", section, flags=re.S).group(1)
    exe = str(Path(sys.executable).parent / "postcapture")
    path = tmp_path / "target3t.toml"
    assert subprocess.run([exe, "scenario", "new", "--like", "envisat", "-o", str(path)], capture_output=True,
                          timeout=60).returncode == 0
    scenario_text = path.read_text()
    start = scenario_text.index("[target]\n")
    end = scenario_text.index("# A post-capture manoeuvre")  # the [[excitation]] tables follow the target
    edited = scenario_text[:start] + block + "\n" + scenario_text[end:]
    edited = re.sub(r"(?m)^target_mass = \{ sigma = 100.0 \}.*$", "target_mass = { sigma = 30.0 }", edited)
    path.write_text(edited)
    done = subprocess.run([exe, "scenario", "validate", str(path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "valid scenario 'target3t': 7 arm joints, 2 panels, a target of 3000 kg, 300 s" in " ".join(done.stdout.split())
    scenario = load_scenario(path)
    assert scenario.target.mass == 3000.0 and scenario.target.panels[0].name == "wing_3t"
    assert tomllib.loads(block)["target"]["inertia"][1][1] == 3000.0 * (3.0**2 + 2.0**2) / 12  # the box formula

    from postcapture.dynamics.build import build_system

    system = build_system(scenario, "flexible")
    assert system.nv == 6 + 7 + 6 + 6  # free flyer, arm, chaser wing and target wing (5 bends + torsion each)
