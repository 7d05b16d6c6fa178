"""Where a result came from: the package version, the source commit, the command line, the time, the scenario.

:func:`provenance` gathers them once per result; ``summary.json`` holds them under ``"provenance"`` and the
NetCDF files as global attributes (:func:`as_attributes`), so a file found later says what made it.
"""

from __future__ import annotations

import datetime as _dt
import functools
import os
import shlex
import subprocess
import sys

__all__ = ["provenance", "as_attributes", "source_commit"]


@functools.lru_cache(maxsize=1)
def source_commit() -> str | None:
    """The git commit of the package's source (``-dirty`` when it has uncommitted changes), or None when the
    package was not installed from a git checkout."""
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        done = subprocess.run(["git", "-C", here, "describe", "--always", "--dirty", "--abbrev=40"],
                              capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    text = done.stdout.strip()
    return text if done.returncode == 0 and text else None


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("postcapture")
    except PackageNotFoundError:  # pragma: no cover - a source tree on sys.path
        return "unknown"


def provenance(scenario=None, *, argv: list[str] | None = None) -> dict:
    """What made a result.

    Parameters
    ----------
    scenario : pydantic model, optional
        The scenario (anything with ``model_dump``): recorded as TOML, so that the run can be repeated from
        the file alone (``postcapture run --scenario that.toml``).
    argv : list of str, optional
        The command line (default ``sys.argv``; ``python -c``/a notebook give what Python recorded).

    Returns
    -------
    dict
        ``postcapture_version``, ``source_commit`` (None outside a git checkout), ``command_line``,
        ``date_created`` (UTC, ISO 8601), ``python``, and ``scenario_toml`` when a scenario is given.
    """
    argv = list(sys.argv if argv is None else argv)
    if argv:
        argv[0] = os.path.basename(argv[0]) or argv[0]
    out = {
        "postcapture_version": _version(),
        "source_commit": source_commit(),
        "command_line": shlex.join(argv),
        "date_created": _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat(),
        "python": sys.version.split()[0],
    }
    if scenario is not None:
        import tomli_w

        from postcapture.io.jsontext import plain

        out["scenario_toml"] = tomli_w.dumps(plain(scenario.model_dump(exclude_none=True)))
    return out


def as_attributes(prov: dict) -> dict:
    """NetCDF global attributes of a provenance: strings only (a missing commit is ``"unknown"``), and a CF
    ``history`` line."""
    attrs = {k: ("unknown" if v is None else str(v)) for k, v in prov.items()}
    attrs["history"] = f"{attrs.get('date_created', '')} {attrs.get('command_line', '')} (postcapture " \
                       f"{attrs.get('postcapture_version', '')})".strip()
    return attrs
