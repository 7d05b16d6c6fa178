"""Every Python block of the README runs: blocks written as a session (``>>>``) are doctests."""

import doctest
import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
SESSIONS = [b for b in BLOCKS if b.lstrip().startswith(">>>")]
SCRIPTS = [b for b in BLOCKS if not b.lstrip().startswith(">>>")]


@pytest.mark.parametrize("code", SCRIPTS, ids=[f"block{i}" for i in range(len(SCRIPTS))])
def test_readme_python_block_runs(code, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    exec(compile(code, str(README), "exec"), {})
    out = capsys.readouterr().out
    assert "DoF; first mode" in out or out


@pytest.mark.parametrize("session", SESSIONS, ids=[f"session{i}" for i in range(len(SESSIONS))])
def test_readme_session_is_a_passing_doctest(session, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    parser = doctest.DocTestParser()
    test = parser.get_doctest(session, {}, "README", str(README), 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.attempted > 0 and result.failed == 0


def test_readme_has_the_facade_sessions():
    text = "\n".join(SESSIONS)
    for call in ("pc.load_scenario(", "pc.simulate(", "pc.run(", ".to_xarray()", ".to_pandas()", "pc.calibrate_panel(",
                 "pc.export_fmu("):
        assert call in text, call
