"""The ``postcapture`` console script: quiet from its first instant to its last.

Python turns a Ctrl-C into ``KeyboardInterrupt`` wherever it lands, and one that lands while modules are
still being imported, or after :func:`postcapture.cli.main.main` has returned, would print a traceback.
This module (imported by the script alone, never by the library) makes SIGINT end the process with one
line and status 130 until the command's own handler takes over, and again once it has finished. A
SIGINT that the shell set to be ignored (a background job) stays ignored.
"""

import os
import signal
import sys

__all__ = ["run"]


def _interrupted(signum, frame):  # pragma: no cover - exercised through the console script
    try:
        os.write(2, b"postcapture: interrupted\n")
    finally:
        os._exit(130)


_IGNORED = signal.getsignal(signal.SIGINT) is signal.SIG_IGN
if not _IGNORED:
    signal.signal(signal.SIGINT, _interrupted)


def run() -> int:
    """Run the command line; its exit status."""
    try:
        if not _IGNORED:
            signal.signal(signal.SIGINT, signal.default_int_handler)
        from postcapture.cli.main import main

        return main()
    except KeyboardInterrupt:  # between the two handlers
        print("postcapture: interrupted", file=sys.stderr)
        return 130
    finally:  # also after SystemExit (--help, --version, a bad option): interpreter shutdown is quiet too
        if not _IGNORED:
            signal.signal(signal.SIGINT, _interrupted)
