"""Output files: one file or a folder of results written so that a failure never leaves half of it.

* :func:`write_atomic` writes one file through a temporary file beside it, then renames it over the
  target: a reader sees the old file or the new one.
* :class:`ResultSet` writes a folder as a set: into a temporary folder beside it, then swapped in, so
  that a reader sees the old complete set or the new complete set.
* :func:`json_text` writes strict JSON (``null`` for a missing number, never ``NaN``).
* :func:`scratch_folder` gives a build folder that the next build removes if a kill left it.
* :func:`check_output_file` and :func:`check_output_folder` refuse, before any work, a path that is
  not (or would not be) a regular file or folder we may write.

Temporaries are named ``.<target>.postcapture-<pid>-<token>...``; they are removed on every exit path
Python sees, and those of a killed process are removed by the next write to the same target.

This package sits below every layer that writes files (dynamics, panels, fmi, campaign) and imports
nothing else from postcapture but ``core.errors``.
"""

from postcapture.io.atomic import check_output_file, check_output_folder, safe_stem, write_atomic
from postcapture.io.jsontext import json_text, plain
from postcapture.io.result_set import MANIFEST, ResultSet
from postcapture.io.scratch import scratch_folder

__all__ = ["write_atomic", "check_output_file", "check_output_folder", "safe_stem", "ResultSet", "MANIFEST",
           "json_text", "plain", "scratch_folder"]
