"""A folder of results written as one set: a reader sees the old complete set or the new one.

The files go into a temporary folder beside the target; when every file is written, entries of the old
folder that are not part of its set (a user's notes, another command's output) are carried over (hard
links, so nothing is copied), and the new folder is swapped in with one ``renameat2(RENAME_EXCHANGE)``
call. Where the kernel or file system lacks it, two renames do the swap (a reader may then find no folder
for an instant; a crash between them is repaired by the next write). A folder that cannot be renamed
(the working directory or one of its ancestors, a mount point, a parent we may not write) is updated in
place, file by file, each file atomically: a warning says so.

A hidden manifest (:data:`MANIFEST`) lists the files of the set, so that the next set knows which
entries to replace and which to carry.
"""

from __future__ import annotations

import ctypes
import errno
import fnmatch
import json
import logging
import os
import shutil
import stat
from collections.abc import Callable, Sequence
from pathlib import Path

from postcapture.core.errors import OutputPathError
from postcapture.io.atomic import (
    TAG,
    check_output_folder,
    fsync,
    process_alive,
    remove_stale,
    temp_name,
    writer_failure,
)

__all__ = ["MANIFEST", "ResultSet"]

logger = logging.getLogger(__name__)

MANIFEST = ".postcapture_set.json"
_IN_PLACE = "set"  # temporaries inside a folder updated in place: ``.set.postcapture-<pid>-<token>``
_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _version() -> str:
    """This package's version, without importing ``postcapture`` itself (it imports every layer)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("postcapture")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


def _exchange(a: Path, b: Path) -> bool:
    """Swap two paths atomically (Linux ``renameat2``); False where the system cannot."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP):
        return False
    raise OSError(code, os.strerror(code), str(b))


def _link_or_copy(src, dst) -> None:
    try:
        os.link(src, dst, follow_symlinks=False)
    except OSError:
        if not stat.S_ISREG(os.lstat(src).st_mode):
            raise
        shutil.copy2(src, dst)


def _carry(src: Path, dst: Path) -> None:
    """Put ``src`` (an entry of the old folder) at ``dst`` in the new one, sharing the data."""
    mode = os.lstat(src).st_mode
    if stat.S_ISLNK(mode):
        os.symlink(os.readlink(src), dst)
    elif stat.S_ISDIR(mode):
        shutil.copytree(src, dst, symlinks=True, copy_function=_link_or_copy)
    else:
        _link_or_copy(src, dst)


def _check_name(name: str) -> None:
    if (not isinstance(name, str) or not name or name in (".", "..") or "/" in name or "\x00" in name
            or os.sep in name or name == MANIFEST or TAG in name):
        raise ValueError(f"a file name in a result set: expected one plain name, found {name!r}")


class ResultSet:
    """Write a folder of results as one set (see the module docstring).

    Parameters
    ----------
    folder : str or os.PathLike
        The results folder; it must be a folder or not exist.
    owned : sequence of str
        Glob patterns of the names this kind of set writes. In an old folder without a manifest, the
        entries they match count as the old set (replaced); every other entry is carried over.
    kind : str
        What wrote the set (recorded in the manifest).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "res"
    >>> with ResultSet(out, owned=("a.txt",)) as rs:
    ...     _ = rs.write("a.txt", lambda p: pathlib.Path(p).write_text("new"))
    >>> (out / "a.txt").read_text()
    'new'
    """

    def __init__(self, folder, *, owned: Sequence[str] = (), kind: str = "results"):
        self.folder = check_output_folder(folder)
        self.owned = tuple(owned)
        self.kind = kind
        self.names: list[str] = []
        self.in_place = False
        self._tmp: Path | None = None

    # ------------------------------------------------------------------ lifecycle
    def __enter__(self) -> ResultSet:
        parent = self.folder.parent
        parent.mkdir(parents=True, exist_ok=True)
        self._recover()
        remove_stale(parent, self.folder.name)
        self.in_place = not self._swappable()
        if self.in_place:
            logger.warning("%s cannot be swapped as a whole (working folder, mount point or read-only parent): "
                           "its files are replaced one by one", self.folder)
            self.folder.mkdir(exist_ok=True)
            remove_stale(self.folder, _IN_PLACE)
            self._tmp = self.folder / temp_name(_IN_PLACE)
        else:
            self._tmp = parent / temp_name(self.folder.name)
        self._tmp.mkdir()
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        try:
            if exc_type is None:
                self._commit()
        finally:
            self._discard()
        return False

    # ------------------------------------------------------------------ writing
    def write(self, name: str, writer: Callable[[str], object]) -> Path:
        """Write one file of the set: ``writer(path)`` writes it whole; returns its final path."""
        if self._tmp is None:
            raise RuntimeError("ResultSet.write outside its `with` block")
        _check_name(name)
        if name in self.names:
            raise ValueError(f"a file name in a result set: {name!r} is written twice")
        try:
            writer(str(self._tmp / name))
        except Exception as exc:
            failure = writer_failure(exc, self.folder / name)
            if failure is None or failure is exc:
                raise
            raise failure from exc
        self.names.append(name)
        return self.folder / name

    # ------------------------------------------------------------------ internals
    def _swappable(self) -> bool:
        f = self.folder
        if not os.path.lexists(f):
            return True
        real = os.path.realpath(f)
        cwd = os.path.realpath(os.getcwd())
        if cwd == real or cwd.startswith(real.rstrip(os.sep) + os.sep) or os.path.ismount(f):
            return False
        return os.access(f.absolute().parent, os.W_OK | os.X_OK)

    def _recover(self) -> None:
        """After a crash between the two renames of a fallback swap, put the old set back."""
        if os.path.lexists(self.folder):
            return
        prefix = f".{self.folder.name}{TAG}"
        try:
            olds = [e for e in os.scandir(self.folder.parent) if e.name.startswith(prefix) and e.name.endswith(".old")]
        except OSError:
            return
        for entry in olds:
            pid = entry.name[len(prefix):].split("-", 1)[0]
            if pid.isascii() and pid.isdigit() and int(pid) != os.getpid() and not process_alive(int(pid)):
                os.rename(entry.path, self.folder)
                logger.warning("restored %s from %s (an interrupted swap)", self.folder, entry.name)
                return

    def _old_set(self) -> set[str]:
        """Names of the entries of the existing folder that belong to its set."""
        names = {MANIFEST}
        try:
            listed = json.loads((self.folder / MANIFEST).read_text(encoding="utf-8")).get("files", [])
            names |= {n for n in listed if isinstance(n, str)}
        except (OSError, ValueError, AttributeError):
            pass
        try:
            entries = os.listdir(self.folder)
        except FileNotFoundError:
            return names
        names |= {n for n in entries if any(fnmatch.fnmatchcase(n, pat) for pat in self.owned)}
        names |= {n for n in entries if n.startswith(f".{_IN_PLACE}{TAG}")}
        return names

    def _write_manifest(self, where: Path) -> None:
        text = json.dumps({"kind": self.kind, "files": sorted(self.names), "written_by": f"postcapture {_version()}"},
                          indent=1)
        (where / MANIFEST).write_text(text + "\n", encoding="utf-8")

    def _commit(self) -> None:
        tmp = self._tmp
        self._write_manifest(tmp)
        for name in [*self.names, MANIFEST]:
            fsync(tmp / name)
        fsync(tmp, directory=True)
        if self.in_place:
            self._commit_in_place()
            return
        if not os.path.lexists(self.folder):
            try:
                os.rename(tmp, self.folder)
                self._tmp = None
                fsync(self.folder.parent, directory=True)
                return
            except OSError as exc:
                if exc.errno not in (errno.EEXIST, errno.ENOTEMPTY):
                    raise
        check_output_folder(self.folder)  # still a folder: never swap a file or a link away
        ours = self._old_set()
        for entry in os.listdir(self.folder):
            if entry not in ours and entry not in self.names:
                try:
                    _carry(self.folder / entry, tmp / entry)
                except OSError as exc:
                    raise OutputPathError(exc.errno or errno.EIO,
                                          f"cannot carry {entry!r} into the new set ({exc.strerror or exc}); "
                                          "the old set is left as it was", str(self.folder)) from exc
        os.chmod(tmp, stat.S_IMODE(os.stat(self.folder).st_mode))
        if _exchange(tmp, self.folder):
            logger.debug("swapped %s in", self.folder)
        else:
            old = self.folder.parent / temp_name(self.folder.name, ".old")
            os.rename(self.folder, old)
            os.rename(tmp, self.folder)
            self._tmp = old  # removed by _discard
        fsync(self.folder.parent, directory=True)

    def _commit_in_place(self) -> None:
        tmp = self._tmp
        previous = self._old_set() - {MANIFEST}
        for name in self.names:
            target = self.folder / name
            if os.path.lexists(target) and not stat.S_ISREG(os.lstat(target).st_mode):
                raise OutputPathError(errno.EINVAL, "not a regular file (left untouched)", str(target))
        for name in self.names:
            os.replace(tmp / name, self.folder / name)
        os.replace(tmp / MANIFEST, self.folder / MANIFEST)
        for name in previous - set(self.names):
            target = self.folder / name
            if os.path.lexists(target) and stat.S_ISREG(os.lstat(target).st_mode):
                os.unlink(target)
        fsync(self.folder, directory=True)

    def _discard(self) -> None:
        tmp, self._tmp = self._tmp, None
        if tmp is not None and os.path.lexists(tmp):
            shutil.rmtree(tmp, ignore_errors=True)
