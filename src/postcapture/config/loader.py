"""Load a scenario from a built-in name or a TOML file, reporting every problem at once.

Whatever the file holds (any bytes, any nesting, any number), :func:`load_scenario` raises nothing but
:class:`~postcapture.core.errors.ScenarioError`.
"""

from __future__ import annotations

import difflib
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from postcapture.config.faults import FAULT_KINDS
from postcapture.config.schema import Scenario
from postcapture.config.types import NAME_PATTERN
from postcapture.core.errors import Problem, ScenarioError

__all__ = ["MAX_FILE_BYTES", "builtin_scenarios", "load_scenario", "scenario_from_dict", "problems_from_validation"]

MAX_FILE_BYTES = 16 * 2**20
"""Largest scenario file read (bytes); a scenario is a few kilobytes."""


def builtin_scenarios() -> list[str]:
    """Names of the scenarios shipped inside the package."""
    folder = resources.files("postcapture.config") / "scenarios"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


_UNION_TAGS = ("step", "sine", "chirp", "table", *FAULT_KINDS)


def _loc(loc: tuple) -> str:
    out = ""
    previous = None
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif isinstance(previous, int) and part in _UNION_TAGS:
            pass  # the discriminator tag pydantic inserts after a list index (a field may share its name)
        elif isinstance(part, str) and ("[" in part or "(" in part):
            pass  # validator tags
        else:
            out += ("." if out else "") + str(part)
        previous = part
    return out or "(scenario)"


_EXPECTED = {  # pydantic's error type -> what the user should write (``{...}`` from the error's context)
    "missing": "a value (required key)",
    "extra_forbidden": "a known key (this one is not part of the schema)",
    "finite_number": "a finite number",
    "float_parsing": "a number", "float_type": "a number",
    "int_parsing": "an integer", "int_type": "an integer", "int_from_float": "an integer",
    "bool_parsing": "true or false", "bool_type": "true or false",
    "string_type": "a string",
    "dict_type": "a table", "model_type": "a table", "model_attributes_type": "a table",
    "greater_than": "a number > {gt}", "greater_than_equal": "a number >= {ge}",
    "less_than_equal": "a number <= {le}", "less_than": "a number < {lt}",
    "too_short": "at least {min_length} entries", "too_long": "at most {max_length} entries",
    "literal_error": "one of {expected}",
    "string_too_long": "at most {max_length} characters",
}


def _expected(err: dict) -> str:
    kind = err["type"]
    ctx = err.get("ctx") or {}
    if kind == "scenario":
        return ctx["expected"]
    if kind in _EXPECTED:
        return _EXPECTED[kind].format(**{k: str(v) for k, v in ctx.items()})
    if kind == "tuple_type":
        return err["msg"].replace("Tuple should have", "").replace("Input should be", "").strip() or err["msg"]
    if kind == "union_tag_invalid":
        tags = [t.strip(" '") for t in str(ctx.get("expected_tags", "")).split(",")]
        return "kind one of " + ", ".join(tags)
    if kind == "string_pattern_mismatch":
        if ctx.get("pattern") == NAME_PATTERN:
            return "a name: an ASCII letter, then up to 63 ASCII letters, digits, '_', '.' or '-'"
        return "text without control characters (tab and newline allowed)"
    if kind == "union_tag_not_found":
        kinds = FAULT_KINDS if err["loc"][:1] == ("faults",) else ("step", "sine", "chirp", "table")
        return f"a 'kind' key ({', '.join(kinds)})"
    return err["msg"]


def _did_you_mean(word, options) -> str:
    """``" (did you mean 'mass'?)"`` when ``word`` is close to one of ``options``."""
    if not isinstance(word, str) or not options:
        return ""
    close = difflib.get_close_matches(word, [str(o) for o in options], n=2, cutoff=0.6)
    return f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""


def _hint(err: dict, model) -> str:
    """A "did you mean" for a misspelt key, kind or choice."""
    kind, ctx = err["type"], err.get("ctx") or {}
    if kind == "extra_forbidden" and err["loc"]:
        return _did_you_mean(err["loc"][-1], _known_keys(err["loc"][:-1], model))
    if kind == "union_tag_invalid":
        return _did_you_mean(ctx.get("tag"), [t.strip(" '") for t in str(ctx.get("expected_tags", "")).split(",")])
    if kind == "literal_error":
        return _did_you_mean(err.get("input"), _literal_options(ctx))
    return ""


def _literal_options(ctx: dict) -> list[str]:
    return [t.strip(" '") for t in str(ctx.get("expected", "")).replace(" or ", ",").split(",") if t.strip(" '")]


def _known_keys(loc: tuple, model) -> list[str]:
    """The keys the schema ``model`` allows at ``loc`` (a pydantic error location), for "did you mean"."""
    for part in loc:
        if isinstance(part, int) or model is None:
            continue
        if part in _UNION_TAGS or "[" in str(part):
            model = _union_member(model, part)
            continue
        field = model.model_fields.get(part) if hasattr(model, "model_fields") else None
        model = _model_of(field.annotation) if field is not None else None
    return sorted(model.model_fields) if hasattr(model, "model_fields") else []


def _model_of(annotation):
    """The first pydantic model inside an annotation (``Panel`` in ``tuple[Panel, ...] | None``)."""
    if isinstance(annotation, type) and hasattr(annotation, "model_fields"):
        return annotation
    for arg in getattr(annotation, "__args__", ()) or ():
        found = _model_of(arg)
        if found is not None:
            return found
    origin = getattr(annotation, "__origin__", None)
    return _model_of(origin) if origin is not None and origin is not annotation else None


def _union_member(model, tag):
    """The member of a tagged union (excitation or fault kinds) named by ``tag``."""
    from postcapture.config.excitation import Chirp, Sine, Step, Table
    from postcapture.config.faults import BiasStep, JointFault, Outage

    for member in (Step, Sine, Chirp, Table, Outage, BiasStep, JointFault):
        kinds = getattr(member.model_fields.get("kind"), "annotation", None)
        if tag in getattr(kinds, "__args__", ()):
            return member
    return model


def _found(err: dict) -> str:
    if err["type"] == "scenario":
        return err["ctx"]["found"]
    if err["type"] in ("too_short", "too_long") and "actual_length" in (err.get("ctx") or {}):
        return f"{err['ctx']['actual_length']}"
    if err["type"] == "union_tag_invalid":
        return repr((err.get("ctx") or {}).get("tag"))  # the tag alone, not the whole table
    if err["type"] == "missing":
        return "nothing"
    if err["type"] == "extra_forbidden":
        return repr(err["loc"][-1]) if err["loc"] else repr(err.get("input"))
    value = err.get("input")
    if isinstance(value, bool):  # as TOML spells it, and say why it is refused where numbers are due
        return f"{str(value).lower()} (a boolean)"
    try:
        text = repr(value)
    except RecursionError:
        text = f"a deeply nested {type(value).__name__}"
    return text if len(text) < 80 else text[:77] + "..."


def problems_from_validation(exc: ValidationError, model=None) -> list[Problem]:
    """Turn a pydantic ``ValidationError`` into a list of :class:`Problem` (path, expected, found), every one.

    ``model`` is the validated model (default :class:`Scenario`): its fields give the "did you mean" hints.
    """
    model = Scenario if model is None else model
    out = []
    for e in exc.errors():
        ctx = e.get("ctx") or {}
        if e["type"] == "scenario_many":  # one check that found several problems
            out += [Problem(p["path"], p["expected"], p["found"]) for p in ctx["problems"]]
        else:
            path = ctx.get("path") or _loc(tuple(e["loc"])) + (f".{ctx['field']}" if ctx.get("field") else "")
            out.append(Problem(path, _expected(e), _found(e) + _hint(e, model)))
    return out


def scenario_from_dict(data: dict[str, Any], source: str | None = None) -> Scenario:
    """Validate a scenario given as a dict (as read from TOML).

    Raises
    ------
    ScenarioError
        With every problem found (field path, expected, found).
    """
    if not isinstance(data, dict):
        raise ScenarioError([Problem("(scenario)", "a table of sections", type(data).__name__)], source)
    try:
        return Scenario.model_validate(data)
    except ValidationError as exc:
        raise ScenarioError(problems_from_validation(exc), source) from None
    except (RecursionError, ArithmeticError) as exc:  # a validator's arithmetic on an extreme number
        raise ScenarioError([Problem("(scenario)", "numbers and nesting a scenario can hold",
                                     f"{type(exc).__name__}: {exc}")], source) from None


def load_scenario(name_or_path: str | Path = "envisat") -> Scenario:
    """Load a built-in scenario by name (``"envisat"``) or a TOML file by path.

    Raises
    ------
    ScenarioError
        For an unknown name, a missing or unreadable file, invalid TOML, or any schema problem.
    """
    text = str(name_or_path)
    builtins = builtin_scenarios()
    if text in builtins:
        source = f"builtin:{text}"
        raw = (resources.files("postcapture.config") / "scenarios" / f"{text}.toml").read_text(encoding="utf-8")
    else:
        path = Path(text)
        source = str(path)
        try:
            is_file = path.is_file()
        except (OSError, ValueError):  # a name too long for the system, a NUL byte
            is_file = False
        if not is_file:
            looks_like_name = path.suffix == "" and "/" not in text
            what = "unknown scenario name" if looks_like_name else ("not a file" if path.exists() else "no such file")
            raise ScenarioError(
                [Problem("scenario", f"a built-in name ({', '.join(builtins)}) or an existing TOML file", f"{what} {text!r}")],
                source,
            )
        try:
            size = path.stat().st_size
            if size > MAX_FILE_BYTES:
                raise ScenarioError([Problem("scenario", f"a TOML file under {MAX_FILE_BYTES // 2**20} MiB",
                                             f"{size} bytes")], source)
            raw = path.read_bytes().decode("utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ScenarioError([Problem("scenario", "a readable UTF-8 TOML file", str(exc))], source) from None
    raw = raw.removeprefix("\ufeff")  # a UTF-8 byte order mark, as some editors write
    try:
        data = tomllib.loads(raw)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError([Problem("scenario", "valid TOML", str(exc))], source) from None
    except RecursionError:
        raise ScenarioError([Problem("scenario", "TOML nested a few levels deep", "nesting too deep to parse")],
                            source) from None
    return scenario_from_dict(data, source)
