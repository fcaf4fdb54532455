"""Atomic file writing: the target is either fully replaced or left untouched."""

from __future__ import annotations

import errno
import os
import re
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from typing import IO, Any

__all__ = ["WriteError", "atomic_write", "remove_stale_temporaries"]

_REASONS = {
    errno.EACCES: "permission denied",
    errno.EPERM: "permission denied",
    errno.EROFS: "the file system is read-only",
    errno.ENOSPC: "no space left on device",
    errno.EDQUOT: "disk quota exceeded",
    errno.EISDIR: "it is a folder",
}


class WriteError(OSError):
    """A file could not be written; the message names the file and the cause.

    ``errno``, ``strerror`` and ``filename`` are set as for the underlying
    :class:`OSError` when there was one.
    """

    def __init__(self, path: str | os.PathLike[str], reason: str, cause: OSError | None = None):
        self.message = f"cannot write {os.fspath(path)}: {reason}"
        super().__init__(self.message)
        self.filename = os.fspath(path)
        if cause is not None:
            self.errno = cause.errno
            self.strerror = cause.strerror

    def __str__(self) -> str:
        return self.message


def _reason(exc: OSError, folder: str | None = None) -> str:
    """A short, plain description of why writing failed.

    ``folder`` is given when creating the file in it failed, so that a missing
    folder or a path through a regular file can be named.
    """
    if folder is not None and exc.errno == errno.ENOENT:
        return f"folder {folder} does not exist"
    if folder is not None and exc.errno == errno.ENOTDIR:
        return f"{folder} is not a folder"
    if exc.errno in _REASONS:
        return _REASONS[exc.errno]
    text = exc.strerror or str(exc) or type(exc).__name__
    return text[:1].lower() + text[1:]


def _current_umask() -> int:
    """The process umask, read without changing it where the OS allows."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)  # elsewhere: set and restore (not thread-safe)
    os.umask(mask)
    return mask


def _target_mode(path: str) -> int:
    """Permission bits for the new file: the existing file's, else 0o644 minus the umask."""
    try:
        return os.stat(path).st_mode & 0o7777
    except OSError:
        return 0o644 & ~_current_umask()


def _fsync_folder(folder: str) -> None:
    """Make the rename durable; best effort (not every platform can open folders)."""
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


@contextmanager
def atomic_write(path: str | os.PathLike[str], mode: str = "wb") -> Iterator[IO[Any]]:
    """Write a file atomically.

    Data goes to a temporary file in the target's folder, which is flushed,
    fsynced and then renamed onto ``path`` with :func:`os.replace`.  If the
    ``with`` block or the write raises, the temporary file is removed and an
    existing target is left untouched.  An existing file keeps its permission
    bits; a new one gets 0o644 minus the umask.  If ``path`` is a symlink, the
    file it points to is replaced and the link kept.

    Parameters
    ----------
    path : str or path-like
        The file to create or replace.
    mode : {"wb", "w"}
        Binary, or text encoded as UTF-8.

    Yields
    ------
    file object
        Open for writing.

    Raises
    ------
    WriteError
        The file could not be written (missing or read-only folder, full
        disk, ...); the message names the path and the cause.  Other
        exceptions raised inside the block propagate unchanged.
    """
    if mode not in ("wb", "w"):
        raise ValueError(f"atomic_write mode must be 'wb' or 'w', not {mode!r}")
    shown = os.fspath(path)  # the path as the caller gave it, for messages
    # write through a symlink, so that the link stays and its target is replaced
    target = os.path.realpath(shown) if os.path.islink(shown) else os.path.abspath(shown)
    folder = os.path.dirname(target)
    name = os.path.basename(target)
    if os.path.isdir(target):
        raise WriteError(shown, "it is a folder")
    mode_bits = _target_mode(target)
    remove_stale_temporaries(folder)
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{name}.{_MARK}-{os.getpid()}-",
                                   suffix=".tmp")
    except OSError as exc:
        raise WriteError(shown, _reason(exc, folder), exc) from exc
    try:
        if mode == "w":
            f: IO[Any] = os.fdopen(fd, "w", encoding="utf-8")
        else:
            f = os.fdopen(fd, "wb")
    except BaseException:
        os.close(fd)
        _remove(tmp)
        raise
    try:
        with f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, mode_bits)
        os.replace(tmp, target)
    except OSError as exc:
        _remove(tmp)
        # An error about some other file raised inside the block is not ours.
        if isinstance(exc, WriteError) or exc.filename not in (None, tmp, target):
            raise
        raise WriteError(shown, _reason(exc), exc) from exc
    except BaseException:
        _remove(tmp)
        raise
    _fsync_folder(folder)


_MARK = "hybridedit"
_OURS = re.compile(r"^\..+\." + _MARK + r"-(\d+)-[A-Za-z0-9_]{8}\.tmp$")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists but is someone else's
        return True
    return True


def remove_stale_temporaries(folder: str | os.PathLike[str]) -> list[str]:
    """Remove hidden temporary files that a killed write of ours left in ``folder``.

    Ours are named ``.NAME.hybridedit-PID-XXXXXXXX.tmp``; one is stale when no
    process PID runs (a running write's file is never touched). Nothing else is
    ever removed: ``.NAME.XXXXXXXX.tmp`` is the name Python's :mod:`tempfile`
    gives every program's temporaries. Best effort: returns the names removed.
    """
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for e in entries:
        m = _OURS.match(e.name)
        if m is None:
            continue
        try:
            if not _alive(int(m.group(1))) and e.is_file(follow_symlinks=False):
                os.unlink(e.path)
                removed.append(e.name)
        except OSError:
            continue
    return removed


def _remove(tmp: str) -> None:
    try:
        os.unlink(tmp)
    except OSError:
        pass
