"""One output file written atomically, and the checks of output paths made before any work.

A file is written to a temporary file in its own folder (so that the final rename is atomic), flushed to
disk, then renamed over the target. The target must be, or become, a regular file: a folder, a device,
a FIFO, a socket or a symbolic link at that path is refused, never replaced nor written through.
"""

from __future__ import annotations

import errno
import logging
import os
import re
import secrets
import shutil
import stat
from collections.abc import Callable
from pathlib import Path

from postcapture.core.errors import OutputPathError

__all__ = ["TAG", "check_output_file", "check_output_folder", "write_atomic", "temp_name", "remove_stale", "left_by_dead",
           "writer_failure", "process_alive", "fsync", "safe_stem"]

logger = logging.getLogger(__name__)

TAG = ".postcapture-"
"""Marks our temporaries: ``.<target name>.postcapture-<pid>-<token>[suffix]``."""

_KINDS = {
    stat.S_IFREG: "a regular file",
    stat.S_IFDIR: "a folder",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFIFO: "a FIFO (named pipe)",
    stat.S_IFSOCK: "a socket",
    stat.S_IFLNK: "a symbolic link",
}
_NAME_MAX = 255
_DECORATION = len(TAG) + 40  # leading dot, pid, token and suffix of a temporary name


def safe_stem(text: str, *, max_bytes: int = 100) -> str:
    """``text`` made into a plain file-name part: ASCII letters, digits, ``.``, ``_`` and ``-`` only.

    Names from user input (a scenario's or a panel's name) go through it before they become part of a
    file name, so that they cannot point elsewhere (``../x``) or collide with our temporaries.
    """
    out = re.sub(r"[^A-Za-z0-9._-]", "_", str(text)).lstrip(".")[:max_bytes]
    return out or "unnamed"


def temp_name(target: str, suffix: str = "") -> str:
    """A fresh temporary name for ``target`` (a file or folder name), unique to this process."""
    return f".{target}{TAG}{os.getpid()}-{secrets.token_hex(4)}{suffix}"


def process_alive(pid: int) -> bool:
    """Whether a process ``pid`` runs (another user's process counts as running)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def left_by_dead(folder, pid_of) -> list[os.DirEntry]:
    """Entries of ``folder`` that a process which no longer runs left: ``pid_of(name)`` gives the process id in
    an entry's name, or None for an entry that is not such a leftover."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return []
    out = []
    for entry in entries:
        pid = pid_of(entry.name)
        if pid is not None and pid != os.getpid() and not process_alive(pid):  # not ours, nor a running writer's
            out.append(entry)
    return out


def remove_stale(folder: Path, target: str) -> int:
    """Remove the temporaries of ``target`` in ``folder`` left by processes that no longer run.

    Returns the number removed. Only names made by :func:`temp_name` are touched.
    """
    prefix = f".{target}{TAG}"

    def pid_of(name: str) -> int | None:
        head = name[len(prefix):].split("-", 1)[0] if name.startswith(prefix) else ""
        return int(head) if head.isascii() and head.isdigit() else None

    removed = 0
    for entry in left_by_dead(folder, pid_of):
        try:
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
            else:
                os.unlink(entry.path)
            removed += 1
            logger.info("removed %s, left by an interrupted run", entry.path)
        except OSError as exc:
            logger.warning("cannot remove the stale temporary %s: %s", entry.path, exc)
    return removed


def _kind(mode: int) -> str:
    return _KINDS.get(stat.S_IFMT(mode), "of an unknown file type")


def _check_text(path, what: str) -> Path:
    text = os.fspath(path) if isinstance(path, (str, os.PathLike)) else None
    if not isinstance(text, str):
        raise OutputPathError(errno.EINVAL, f"not a {what} path: {path!r}", None)
    if not text.strip():
        raise OutputPathError(errno.EINVAL, f"an empty {what} path", None)
    if "\x00" in text:
        raise OutputPathError(errno.EINVAL, f"a NUL character in a {what} path", repr(text))
    p = Path(text)
    if len(os.fsencode(p.name)) + _DECORATION > _NAME_MAX:
        raise OutputPathError(errno.ENAMETOOLONG, f"the name is too long (at most {_NAME_MAX - _DECORATION} bytes)",
                              text)
    return p


def _lstat(path, what: str):
    """The checked path and its ``lstat`` (None when nothing is there yet)."""
    p = _check_text(path, what)
    try:
        return p, os.lstat(p)
    except (FileNotFoundError, NotADirectoryError):  # the parent check says which part is wrong
        return p, None
    except OSError as exc:
        raise OutputPathError(exc.errno or errno.EIO, exc.strerror or str(exc), str(p)) from None


def _check_parent(p: Path) -> None:
    """The first existing ancestor of ``p`` must be a folder we can create entries in."""
    parent = p.absolute().parent
    while True:
        try:
            st = os.stat(parent)
        except (FileNotFoundError, NotADirectoryError):
            parent = parent.parent
            continue
        except OSError as exc:
            raise OutputPathError(exc.errno or errno.EIO, f"cannot reach {parent}: {exc.strerror}", str(p)) from None
        break
    if not stat.S_ISDIR(st.st_mode):
        raise OutputPathError(errno.ENOTDIR, f"{parent} is {_kind(st.st_mode)}, not a folder", str(p))
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputPathError(errno.EACCES, f"no permission to create files in {parent}", str(p))
    _probe(parent, p)


_PROBE = ".postcapture-probe-"


def _probe(folder: Path, target: Path) -> None:
    """Create and remove an empty file in ``folder``: permissions alone do not tell (``/proc``, a read-only
    or full file system, a root user's ``access``). Its name is not a temporary of the target's (a reader
    watching for a write to begin must not mistake the check for it); one that a kill left is removed here."""
    for entry in left_by_dead(folder, lambda name: _probe_pid(name)):
        try:
            os.unlink(entry.path)
        except OSError:
            pass
    probe = folder / f"{_PROBE}{os.getpid()}-{secrets.token_hex(4)}"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError as exc:
        raise OutputPathError(exc.errno or errno.EIO, f"cannot create files in {folder}: {exc.strerror or exc}",
                              str(target)) from None
    os.close(fd)
    try:
        os.unlink(probe)
    except OSError:
        pass


def _probe_pid(name: str) -> int | None:
    head = name[len(_PROBE):].split("-", 1)[0] if name.startswith(_PROBE) else ""
    return int(head) if head.isascii() and head.isdigit() else None


def check_output_file(path) -> Path:
    """Check that ``path`` can be written as a regular file, before any work; return it as a Path.

    Raises
    ------
    OutputPathError
        For an empty path, a path that exists and is not a regular file (folder, device, FIFO, socket,
        symbolic link), or a parent that is not a folder or not writable.
    """
    p, st = _lstat(path, "file")
    if st is not None and not stat.S_ISREG(st.st_mode):
        raise OutputPathError(errno.EISDIR if stat.S_ISDIR(st.st_mode) else errno.EINVAL,
                              f"{_kind(st.st_mode)}, not a regular file (left untouched)", str(p))
    _check_parent(p)
    return p


def check_output_folder(path) -> Path:
    """Check that ``path`` can be written as a folder of results, before any work; return it as a Path.

    Raises
    ------
    OutputPathError
        For an empty path, a path that exists and is not a folder (file, device, symbolic link, ...), or
        a parent that is not a folder or not writable.
    """
    p, st = _lstat(path, "folder")
    if st is not None and not stat.S_ISDIR(st.st_mode):
        raise OutputPathError(errno.ENOTDIR, f"{_kind(st.st_mode)}, not a folder (left untouched)", str(p))
    if st is not None and not os.access(p, os.W_OK | os.X_OK):
        raise OutputPathError(errno.EACCES, "no permission to write in this folder", str(p))
    _check_parent(p)
    return p


def _space_note(folder: Path) -> str:
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return ""
    return f" ({free} bytes free on that file system)" if free < 64 * 2**20 else ""


def writer_failure(exc: BaseException, target: Path) -> OutputPathError | None:
    """The OutputPathError for a writer's failure (an OSError, or a RuntimeError from a C library such
    as HDF5 on a full disk), or None when the exception is of another kind."""
    if isinstance(exc, OutputPathError):
        return exc
    if isinstance(exc, OSError):
        reason = exc.strerror or str(exc)
        code = exc.errno or errno.EIO
    elif isinstance(exc, RuntimeError):  # HDF5 says "NetCDF: HDF error" for a full disk, among others
        reason, code = f"{exc} (a library's error while writing: a full or read-only file system is one cause)", \
            errno.EIO
    else:
        return None
    return OutputPathError(code, f"write failed: {reason}{_space_note(target.parent)}", str(target))


def fsync(path, directory: bool = False) -> None:
    """Flush a file (or a folder's entries) to disk; a file system that cannot is ignored."""
    try:
        fd = os.open(path, os.O_RDONLY | (os.O_DIRECTORY if directory else 0))
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:  # some file systems cannot sync a folder
        pass
    finally:
        os.close(fd)


def write_atomic(path, writer: Callable[[str], object]) -> Path:
    """Call ``writer(tmp_path)``, then rename the file onto ``path``: a failure never leaves half a file.

    The temporary file sits in the destination folder (created if missing) so that the rename is
    atomic; it is removed when the writer fails or the process is interrupted.

    Parameters
    ----------
    path : str or os.PathLike
        The file to write; it must be a regular file or not exist.
    writer : callable(str)
        Writes the whole file at the path it is given.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    OutputPathError
        When ``path`` is not a regular file (left untouched), cannot be created, or the writer fails
        with an OSError or a library's RuntimeError (disk full, ...).
    """
    path = check_output_file(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale(path.parent, path.name)
    tmp = path.parent / temp_name(path.name, ".tmp")
    try:
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))  # umask gives the usual permissions
    except OSError as exc:  # the message names the target, not our temporary
        raise OutputPathError(exc.errno or errno.EIO, f"cannot create a file beside it: {exc.strerror or exc}",
                              str(path)) from None
    try:
        try:
            writer(str(tmp))
        except Exception as exc:
            failure = writer_failure(exc, path)
            if failure is None or failure is exc:
                raise
            raise failure from exc
        fsync(tmp)
        check_output_file(path)  # nothing else appeared there meanwhile
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    fsync(path.parent, directory=True)
    return path
