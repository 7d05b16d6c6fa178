"""Scenario files for users: the text of a built-in scenario, a new file to edit, a check of a file.

Behind ``postcapture scenario show|new|validate``. A new scenario starts as a copy of a built-in one,
comments and sources included, under a new name; the field reference
(:mod:`postcapture.config.reference`) says what each field means, its unit, default and bounds.
"""

from __future__ import annotations

import re
from importlib import resources
from pathlib import Path

from postcapture.config.loader import builtin_scenarios, load_scenario
from postcapture.config.types import NAME_PATTERN
from postcapture.core.errors import Problem, ScenarioError

__all__ = ["builtin_text", "new_scenario_text", "check_scenario_file"]


def builtin_text(name: str) -> str:
    """The TOML text of a built-in scenario, comments and cited sources included.

    Raises
    ------
    ScenarioError
        For a name that is not built in.
    """
    names = builtin_scenarios()
    if name not in names:
        raise ScenarioError([Problem("scenario", f"a built-in name ({', '.join(names)})", repr(name))])
    return (resources.files("postcapture.config") / "scenarios" / f"{name}.toml").read_text(encoding="utf-8")


def new_scenario_text(like: str, name: str) -> str:
    """A copy of the built-in scenario ``like`` renamed ``name`` (its comments kept), ready to edit.

    Raises
    ------
    ScenarioError
        For an unknown ``like``, or a ``name`` that is not a plain name.
    """
    if not re.fullmatch(NAME_PATTERN, name, re.ASCII):
        raise ScenarioError([Problem("name", "a name: an ASCII letter, then up to 63 ASCII letters, digits, '_', '.' "
                                             "or '-' (it is taken from the output file's name)", repr(name))])
    text = builtin_text(like)
    head = (f"# A scenario of your own, started from the built-in '{like}' (postcapture scenario new).\n"
            "# Every field, its unit, default and bounds: docs/scenario-reference.md, or `postcapture scenario "
            "reference`.\n# Check it with `postcapture scenario validate FILE`.\n\n")
    renamed, count = re.subn(r'(?m)^name = "[^"]*"', f'name = "{name}"', text, count=1)
    if count != 1:  # pragma: no cover - every built-in scenario starts with its name
        raise ScenarioError([Problem("like", "a built-in scenario with a top-level name", like)])
    return head + renamed


def check_scenario_file(path) -> tuple[object | None, list[Problem]]:
    """``(scenario, [])`` for a valid file, ``(None, problems)`` with every problem otherwise."""
    try:
        return load_scenario(Path(path) if not isinstance(path, Path) else path), []
    except ScenarioError as exc:
        return None, list(exc.problems)
