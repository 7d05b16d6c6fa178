"""The ``postcapture`` command line (console script ``postcapture = postcapture.cli:main``)."""

from postcapture.cli.main import build_parser, main

__all__ = ["main", "build_parser"]
