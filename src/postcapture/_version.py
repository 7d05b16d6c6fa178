"""The installed package's version, in a module of its own: layers below the top-level package read it
here, so that they never import ``postcapture`` itself (which re-exports the top-level API)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("postcapture")
except PackageNotFoundError:  # pragma: no cover - running from a source tree
    __version__ = "0.0.0"

__all__ = ["__version__"]
