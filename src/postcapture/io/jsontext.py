"""Strict JSON for every document the package writes or prints (``--json``, ``summary.json``, file attributes).

JSON has no NaN or infinity (RFC 8259); Python's :mod:`json` writes them anyway as ``NaN`` and
``Infinity``, which strict parsers (``jq``, JavaScript, Go, Rust's serde) refuse. Here a missing or
undefined number is ``null``, numpy scalars and arrays become plain numbers and lists, and anything else
that JSON cannot hold is an error (never a silent ``str``).
"""

from __future__ import annotations

import json
import math
from pathlib import PurePath

__all__ = ["plain", "json_text"]


def plain(obj):
    """``obj`` with only JSON's types: dict (string keys), list, str, int, finite float, bool, None.

    NaN and infinities become None; numpy scalars and arrays, tuples and paths become their plain values.

    Examples
    --------
    >>> plain({"a": float("nan"), "b": (1, 2.5)})
    {'a': None, 'b': [1, 2.5]}
    """
    if obj is None or isinstance(obj, (bool, str)):
        return obj
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {str(k): plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v) for v in obj]
    if isinstance(obj, PurePath):
        return str(obj)
    if hasattr(obj, "tolist"):  # numpy scalars and arrays
        return plain(obj.tolist())
    raise TypeError(f"a value JSON can hold: expected numbers, strings, lists or tables, found {type(obj).__name__}")


def json_text(obj, *, indent: int | None = 2) -> str:
    """Strict JSON text of ``obj`` (see :func:`plain`)."""
    return json.dumps(plain(obj), indent=indent, allow_nan=False, ensure_ascii=False)
