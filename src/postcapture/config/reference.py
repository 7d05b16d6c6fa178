"""The field reference of the scenario file: every field with its unit, default and bounds, generated from the schema.

Nothing here lists fields by hand: :func:`field_rows` walks :class:`~postcapture.config.schema.Scenario`
and reads what each field declares (its type, :func:`~postcapture.config.types.quantity`'s unit and
bounds, :func:`~postcapture.config.uncertainty.prior_field`'s role and limit, its default, and its line in
the class docstring's ``Parameters`` section when there is one). A field added to the schema appears
here, with its unit and bounds, as soon as it declares them. :func:`reference_markdown` is the page
``docs/scenario-reference.md`` (a test keeps that file equal to it); ``postcapture scenario reference``
prints it.
"""

from __future__ import annotations

import inspect
import json
import re
import types
import typing
from dataclasses import dataclass

import annotated_types
from pydantic import BaseModel
from pydantic.fields import FieldInfo
from pydantic_core import PydanticUndefined

__all__ = ["FieldRow", "field_rows", "reference_markdown"]


@dataclass(frozen=True)
class FieldRow:
    """One field of the scenario file.

    Attributes
    ----------
    path : str
        Where it sits in the file: ``target.panels[].length`` (``[]``: an array of tables).
    kind : str
        What it takes: ``number``, ``integer``, ``text``, ``one of ...``, ``3 numbers``, ``table``, ...
    unit : str
        SI unit (``""`` for none, ``1`` for a plain factor).
    default : str
        ``required``, or the value taken when the key is left out.
    bounds : str
        The values allowed (``> 0, <= 1e+07``), as the loader checks them.
    doc : str
        What it means, from the schema's docstrings.
    """

    path: str
    kind: str
    unit: str
    default: str
    bounds: str
    doc: str


def _strip_optional(ann):
    args = typing.get_args(ann)
    if typing.get_origin(ann) in (typing.Union, types.UnionType) and type(None) in args:
        rest = [a for a in args if a is not type(None)]
        return rest[0] if len(rest) == 1 else typing.Union[tuple(rest)], True
    return ann, False


def _field_infos(ann) -> list[FieldInfo]:
    """Every ``FieldInfo`` inside an annotation (``Annotated[float, Field(...)]`` nested in tuples and unions)."""
    out = []
    if typing.get_origin(ann) is typing.Annotated:
        out += [m for m in ann.__metadata__ if isinstance(m, FieldInfo)]
    for arg in typing.get_args(ann):
        if not isinstance(arg, (str, int, float)):
            out += _field_infos(arg)
    return out


def _models(ann) -> list[type[BaseModel]]:
    """The pydantic models a field holds (union members in order)."""
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return [ann]
    out = []
    for arg in typing.get_args(ann):
        if not isinstance(arg, (str, int, float)):
            out += [m for m in _models(arg) if m not in out]
    return out


def _kind(ann) -> str:
    ann, optional = _strip_optional(ann)
    base = ann
    while typing.get_origin(base) is typing.Annotated:
        base = typing.get_args(base)[0]
    origin, args = typing.get_origin(base), typing.get_args(base)
    if origin is typing.Literal:
        text = "one of " + ", ".join(repr(a) for a in args)
    elif origin is tuple and args and args[-1] is Ellipsis:
        inner = _kind(args[0])
        text = f"array of {inner}" + ("s" if not inner.endswith("s") and " " not in inner else "")
    elif origin is tuple:
        inners = {_kind(a) for a in args}
        inner = inners.pop() if len(inners) == 1 else "value"
        if inner.endswith(" numbers") and inner[0].isdigit():  # a matrix: 3 rows of 3 numbers
            text = f"{len(args)}x{inner}"
        else:
            text = f"{len(args)} {inner}s"
    elif origin is dict:
        text = f"tables by name ({_kind(args[1])})"
    elif _models(base):
        names = [m.__name__ for m in _models(base)]
        text = "table" if len(names) == 1 else "table, by kind"
    else:
        text = {float: "number", int: "integer", str: "text", bool: "true or false"}.get(base, str(base))
    return text + (" (optional)" if optional else "")


def _bounds_of(metadata, text: bool = False) -> list[str]:
    out = []
    what = "characters" if text else "entries"
    for m in metadata:
        for attr, sign in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<=")):
            value = getattr(m, attr, None)
            if isinstance(m, getattr(annotated_types, attr.capitalize())) and value is not None:
                out.append(f"{sign} {value:g}")
        if isinstance(m, annotated_types.MinLen):
            out.append(f"at least {m.min_length} {what}")
        if isinstance(m, annotated_types.MaxLen):
            out.append(f"at most {m.max_length} {what}")
        if getattr(m, "pattern", None):
            out.append(_PATTERNS.get(m.pattern, "text without control characters"))
    return out


def _unit_and_bounds(info: FieldInfo) -> tuple[str, str]:
    extra = dict(info.json_schema_extra or {}) if isinstance(info.json_schema_extra, dict) else {}
    text = _strip_optional(info.annotation)[0] is str
    bounds = _bounds_of(info.metadata, text)
    for inner in _field_infos(info.annotation):
        inner_extra = inner.json_schema_extra if isinstance(inner.json_schema_extra, dict) else {}
        extra = {**inner_extra, **extra}
        if not bounds:
            bounds = _bounds_of(inner.metadata, typing.get_args(inner.annotation) == () and inner.annotation is str)
    if "bounds" in extra:
        bounds.append(str(extra["bounds"]))
    if "role" in extra:
        limit = extra["limit"]
        bounds.append(f"draws in (0, {limit:g}]" if extra["role"] == "factor" else f"draws within +-{limit:g}")
    elif "limit" in extra:
        bounds.append(f"each component at most {extra['limit']}")
    unit = str(extra.get("unit", ""))
    return ("" if unit == "name" else unit), ", ".join(dict.fromkeys(bounds))


def _default(info: FieldInfo) -> str:
    if info.is_required():
        return "required"
    value = info.get_default(call_default_factory=True)
    if isinstance(value, BaseModel):
        return "(table of defaults)"
    if value is None:
        return "none"
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(f"{v:g}" if isinstance(v, float) else repr(v) for v in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, dict):
        return "{}"
    if isinstance(value, str):
        return json.dumps(value)
    return repr(value)


_PATTERNS = {}  # filled below: pattern -> what it allows
_PARAM = re.compile(r"^(\w+(?:, \w+)*) : .*$")


def _docs(model: type[BaseModel]) -> dict[str, str]:
    """Field docs from numpydoc ``Parameters`` or ``Attributes`` sections of the class's docstrings (its bases
    first, so that a subclass may say more)."""
    out: dict[str, str] = {}
    for cls in reversed(model.__mro__):
        if cls.__dict__.get("__doc__") and issubclass(cls, BaseModel):
            out.update(_doc_entries(cls.__doc__))
    return out


def _doc_entries(text: str) -> dict[str, str]:
    doc = inspect.cleandoc(text)
    out, names, lines = {}, [], []
    for line in doc.splitlines():
        m = _PARAM.match(line)
        if m:
            if names:
                for n in names:
                    out[n] = " ".join(lines)
            names, lines = [n.strip() for n in m.group(1).split(",")], []
        elif names and line.startswith("    "):
            lines.append(line.strip())
        elif names and not line.strip():
            continue
        elif names:
            for n in names:
                out[n] = " ".join(lines)
            names, lines = [], []
    for n in names:
        out[n] = " ".join(lines)
    return out


def _patterns() -> dict[str, str]:
    from postcapture.config.types import NAME_PATTERN

    return {NAME_PATTERN: "a plain name: an ASCII letter, then up to 63 letters, digits, _ . -"}


def _summary(model: type[BaseModel]) -> str:
    return inspect.cleandoc(model.__doc__ or "").split("\n\n")[0].replace("\n", " ")


def field_rows(model: type[BaseModel] | None = None, prefix: str = "") -> list[FieldRow]:
    """Every field of ``model`` (default: the whole scenario), depth first, tables after their own row."""
    if model is None:
        from postcapture.config.schema import Scenario

        model = Scenario
    _PATTERNS.update(_patterns())
    docs = _docs(model)
    rows = []
    listed: dict[type, str] = {}  # a table type listed once per level (ten priors share one Prior)
    for name, info in model.model_fields.items():
        ann = info.annotation
        path = f"{prefix}{name}"
        inner, _ = _strip_optional(ann)
        sequence = typing.get_origin(inner) is tuple or typing.get_origin(inner) is dict
        unit, bounds = _unit_and_bounds(info)
        subs = _models(ann)
        doc = info.description or docs.get(name, "")
        if not doc and len(subs) == 1:
            doc = _summary(subs[0])
        rows.append(FieldRow(path, _kind(ann), unit, _default(info), bounds, doc))
        below = f"{path}[]." if typing.get_origin(inner) is tuple else f"{path}.<name>." if sequence else f"{path}."
        if len(subs) == 1 and subs[0] in listed:
            rows[-1] = FieldRow(path, rows[-1].kind, unit, rows[-1].default, bounds,
                                f"{doc} Keys as `{listed[subs[0]]}`.".strip())
            continue
        if len(subs) == 1:
            listed[subs[0]] = f"{path}"
        for sub in subs:
            if len(subs) > 1:  # a tagged union: each kind's fields
                kinds = typing.get_args(sub.model_fields["kind"].annotation)
                rows.append(FieldRow(f"{below}kind = {kinds[0]!r}" if len(kinds) == 1 else f"{below}kind",
                                     "kind", "", "", "", _summary(sub)))
            rows += [r for r in field_rows(sub, below) if not (len(subs) > 1 and r.path == f"{below}kind")]
    return rows


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def reference_markdown() -> str:
    """The field reference page (Markdown)."""
    head = [
        "# Scenario file: field reference",
        "",
        "Generated from the schema by `postcapture scenario reference` (do not edit: a test compares this page",
        "with the schema). Units are SI; `1` is a plain factor. A field marked *required* has no default; a",
        "value outside its bounds is refused when the file is loaded, with the field's path. `[]` marks an",
        "array of tables (`[[target.panels]]`), `<name>` a table keyed by a name (`[estimation.tuning.realistic]`).",
        "Priors (`[uncertainty]`) are tables `{ sigma = ... }` (normal, cut at `truncate` sigmas) or",
        "`{ kind = \"uniform\" | \"loguniform\", low = ..., high = ... }`; their bound applies to every draw.",
        "",
        "| field | takes | unit | default | bounds | meaning |",
        "|---|---|---|---|---|---|",
    ]
    body = [f"| `{r.path}` | {_cell(r.kind)} | {_cell(r.unit)} | {_cell(r.default)} | {_cell(r.bounds)} | "
            f"{_cell(r.doc)} |" for r in field_rows()]
    return "\n".join(head + body) + "\n"
