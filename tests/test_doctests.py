"""The examples in the docstrings run (numpydoc ``Examples`` sections)."""

import doctest
import importlib

import pytest

MODULES = [
    "postcapture.facade",
    "postcapture.core.units",
    "postcapture.dynamics.simulate",
    "postcapture.dynamics.trajectory",
    "postcapture.report.style",
    "postcapture.report.table",
]


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False)
    assert result.attempted > 0, f"{name} has no examples"
    assert result.failed == 0
