"""Scratch folders for builds (an FMU's sources and objects) that a killed process cannot leave behind for good.

A scratch folder is named ``<kind>-<pid>-<random>`` in the system's temporary folder. It is removed when
its ``with`` block ends, however it ends; a process killed outright (SIGKILL, a power cut) cannot do
that, so every new scratch folder of the same kind first removes those whose process no longer runs.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import shutil
import tempfile
from pathlib import Path

from postcapture.io.atomic import left_by_dead

__all__ = ["scratch_folder", "remove_stale_scratch"]

logger = logging.getLogger(__name__)


def remove_stale_scratch(kind: str, folder: str | os.PathLike | None = None) -> int:
    """Remove the scratch folders of ``kind`` left in ``folder`` (default: the temporary folder) by processes that
    no longer run; returns how many."""
    base = Path(folder if folder is not None else tempfile.gettempdir())
    pattern = re.compile(re.escape(kind) + r"-([0-9]+)-[A-Za-z0-9_]+", re.ASCII)

    def pid_of(name: str) -> int | None:
        m = pattern.fullmatch(name)
        return int(m.group(1)) if m else None

    removed = 0
    for entry in left_by_dead(base, pid_of):
        if entry.is_dir(follow_symlinks=False):
            shutil.rmtree(entry.path, ignore_errors=True)
            removed += not os.path.lexists(entry.path)
            logger.info("removed %s, left by a process that was killed", entry.path)
    return removed


@contextlib.contextmanager
def scratch_folder(kind: str, folder: str | os.PathLike | None = None):
    """A fresh folder ``<kind>-<pid>-<random>`` for the duration of a ``with`` block (see the module docstring)."""
    remove_stale_scratch(kind, folder)
    path = Path(tempfile.mkdtemp(prefix=f"{kind}-{os.getpid()}-", dir=folder))
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)
