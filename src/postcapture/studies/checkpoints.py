"""A campaign's checkpoints: one file per finished run that proves what it holds.

Each run is saved as ``OUT/runs/run_NNNNN.npz`` (numpy's zip of arrays, no pickles) with a small JSON
header that records

- ``run``: the run number, which must be the one in the file's name;
- ``settings_sha256``: the hash of the campaign's settings (its manifest), so that a file copied in from
  another campaign is recognised;
- ``content_sha256``: the hash of every array (name, dtype, shape and bytes) and of the header itself,
  so that a truncated, damaged or edited file is recognised.

:func:`saved_runs` loads every checkpoint that passes these checks. Anything else found in the folder
(an empty, truncated or random file, a stray ``run_00001 (copy).npz``, another campaign's run, a run
saved under another run's name) is moved aside into ``OUT/runs/set_aside/`` with one warning naming it,
and its run is computed again: a campaign never counts a run twice nor a run it did not compute.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import re
from pathlib import Path

import numpy as np

from postcapture.io import write_atomic

__all__ = ["FORMAT", "SET_ASIDE", "CheckpointError", "settings_digest", "checkpoint_name", "save_run", "load_run",
           "saved_runs"]

logger = logging.getLogger(__name__)

FORMAT = 2
"""Version of the checkpoint layout (1: before the hashes; such files are recomputed)."""

SET_ASIDE = "set_aside"
"""Sub-folder of ``runs/`` where files that are not valid checkpoints of the campaign are moved."""

RUN_ARRAYS = ("mass_error", "mass_sigma", "attitude_error", "attitude_sigma", "attitude_nees", "com_error",
              "inertia_error", "com_sigma", "inertia_sigma")
"""The per-case arrays of a run that a checkpoint holds."""

_NAME = re.compile(r"run_([0-9]{5,})\.npz", re.ASCII)


class CheckpointError(ValueError):
    """A file that is not a valid checkpoint of this campaign's run (the reason is the message)."""


def settings_digest(settings: dict) -> str:
    """SHA-256 of a campaign's settings (canonical JSON: sorted keys, no spaces)."""
    text = json.dumps(settings, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def checkpoint_name(run: int) -> str:
    """``run_00007.npz``: the file name of run ``run``."""
    return f"run_{int(run):05d}.npz"


def _content_digest(arrays: dict[str, np.ndarray], header: dict) -> str:
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}|{a.dtype.str}|{a.shape}|".encode())
        h.update(a.tobytes())
    h.update(json.dumps(header, sort_keys=True, separators=(",", ":")).encode())
    return h.hexdigest()


def save_run(folder: Path, result: dict, digest: str) -> Path:
    """Write run ``result["run"]`` of a campaign whose settings hash to ``digest``; returns the path."""
    arrays = {"truth": np.asarray(result["truth"], dtype=float),
              "true_mass": np.asarray(result["true_mass"], dtype=float)}
    header = {"format": FORMAT, "run": int(result["run"]), "settings_sha256": digest, "cases": {}}
    for case, c in result["cases"].items():
        for key in RUN_ARRAYS:
            arrays[f"{case}/{key}"] = np.asarray(c[key], dtype=float)
        header["cases"][case] = {"diverged_at": float(c["diverged_at"]), "message": c["message"]}
    header["content_sha256"] = _content_digest(arrays, header)

    def write(tmp):
        with open(tmp, "wb") as f:  # a file object: savez would append ".npz" to a temporary name
            np.savez(f, **arrays, header=np.array(json.dumps(header)))

    return write_atomic(Path(folder) / checkpoint_name(result["run"]), write)


def _read(path: Path) -> tuple[dict, dict]:
    """The header and arrays of a file; CheckpointError for anything that is not one of our files."""
    try:
        with np.load(path, allow_pickle=False) as z:
            files = list(z.files)
            if "header" not in files:
                raise CheckpointError("no checkpoint header (a file of an earlier version, or not a checkpoint)")
            header = json.loads(str(z["header"]))
            arrays = {name: z[name] for name in files if name != "header"}
    except CheckpointError:
        raise
    except Exception as exc:  # a damaged file can fail in zipfile, numpy or json in many ways; all mean "bad file"
        raise CheckpointError(f"unreadable ({type(exc).__name__}: {exc})") from None
    if not isinstance(header, dict):
        raise CheckpointError("a header that is not a table")
    return header, arrays


def load_run(path: Path, *, run: int, digest: str) -> dict:
    """Load run ``run`` from ``path`` after checking it (see the module docstring).

    Raises
    ------
    CheckpointError
        When the file is unreadable, of another layout, of another campaign, of another run, or damaged.
    """
    header, arrays = _read(Path(path))
    if header.get("format") != FORMAT:
        raise CheckpointError(f"layout {header.get('format')!r}, expected {FORMAT}")
    if header.get("settings_sha256") != digest:
        raise CheckpointError("saved by a campaign with other settings")
    if header.get("run") != run:
        raise CheckpointError(f"holds run {header.get('run')!r}, not run {run}")
    claimed = header.pop("content_sha256", None)
    if claimed != _content_digest(arrays, header):
        raise CheckpointError("its content does not match its hash (damaged or edited)")
    cases = header.get("cases")
    try:
        out = {"run": run, "truth": arrays["truth"], "true_mass": float(arrays["true_mass"]), "cases": {}}
        for case, info in cases.items():
            c = {key: arrays[f"{case}/{key}"] for key in RUN_ARRAYS}
            c.update(diverged_at=float(info["diverged_at"]), message=info["message"])
            out["cases"][case] = c
    except (KeyError, TypeError, AttributeError, ValueError) as exc:
        raise CheckpointError(f"incomplete ({type(exc).__name__}: {exc})") from None
    return out


def _set_aside(path: Path, reason: str) -> Path:
    """Move ``path`` into ``set_aside/`` (never over an earlier file there) and say so, once."""
    folder = path.parent / SET_ASIDE
    folder.mkdir(exist_ok=True)
    target = folder / path.name
    k = 1
    while os.path.lexists(target):
        target = folder / f"{path.name}.{k}"
        k += 1
    os.rename(path, target)
    logger.warning("%s: %s; moved to %s", path, reason, target)
    return target


def saved_runs(folder: Path, *, digest: str, runs: int, cases) -> dict[int, dict]:
    """Every valid checkpoint of the campaign in ``folder``, by run number (runs ``0 .. runs - 1``).

    Files that are not valid checkpoints of this campaign, or hold other cases, are moved aside (see the
    module docstring); their runs are then missing, so the campaign computes them again.
    """
    folder = Path(folder)
    found: dict[int, dict] = {}
    try:
        entries = sorted(p for p in folder.iterdir() if p.name.startswith("run_") and p.is_file())
    except FileNotFoundError:
        return found
    for path in entries:
        m = _NAME.fullmatch(path.name)
        if m is None:
            _set_aside(path, "not a checkpoint name (run_NNNNN.npz)")
            continue
        run = int(m.group(1))
        try:
            result = load_run(path, run=run, digest=digest)
            if run >= runs:
                raise CheckpointError(f"run {run} is beyond this campaign's {runs} runs")
            if sorted(result["cases"]) != sorted(cases):
                raise CheckpointError("holds other cases")
        except CheckpointError as exc:
            _set_aside(path, f"not a valid checkpoint of this campaign ({exc}); its run is computed again")
            continue
        found[run] = result
    return found
