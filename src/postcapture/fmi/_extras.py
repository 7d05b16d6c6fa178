"""Lazy imports of the optional ``fmi`` extra (FMPy).

``import postcapture.fmi`` works without them; the functions that need them call these helpers, which
raise :class:`~postcapture.core.errors.MissingExtraError` naming the extra to install.
"""

from __future__ import annotations

import importlib
from types import ModuleType

from postcapture.core.errors import MissingExtraError

__all__ = ["import_fmpy"]


def _load(name: str) -> ModuleType:
    try:
        return importlib.import_module(name)
    except ImportError as exc:
        raise MissingExtraError(name, "fmi") from exc


def import_fmpy() -> ModuleType:
    """The ``fmpy`` module, or :class:`MissingExtraError` ``("fmpy", "fmi")``."""
    return _load("fmpy")
