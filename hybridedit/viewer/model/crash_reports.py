"""Crash reports: an unexpected error written down, with its traceback, in the user cache folder.

An error the program raises in words about the input, the selection or a file (a
:class:`ValueError` such as :class:`~hybridedit.core.mesh.MeshError` or
:class:`~hybridedit.deform.selection.SelectionError`, an :class:`OSError`, a
:class:`MemoryError`) is the user's to act on and is only said; anything else is a bug
(:func:`is_crash`): the window says what failed in one line (:func:`failure_message`) and
writes a report (:func:`write_crash_report`) to ``<cache>/crash-reports/``, naming its path.
Qt-free: another front end reports the same way.
"""

from __future__ import annotations

import datetime
import platform
import re
import sys
import traceback
from pathlib import Path

import numpy as np

from ... import __version__
from ...core.cache_dir import default_cache_dir
from ...fileio.atomic import atomic_write

__all__ = ["KEEP", "describe", "failure_message", "is_crash", "reports_folder", "session_details",
           "write_crash_report"]

KEEP = 20
"""Crash reports kept in the folder: writing one removes all but the newest this many."""
FOLDER = "crash-reports"
"""The reports' folder in the user cache folder."""
_NAME = re.compile(r"^\d{8}-\d{6}-\d{6}-[a-z0-9-]*\.txt$")  # ours: <date>-<time>-<microseconds>-<slug>.txt
_SAID = (ValueError, OSError, MemoryError)
"""The errors said in words, not reported (a ValueError is how the library names a bad value)."""
_LIBRARIES = ("numpy", "scipy", "numba", "vtkmodules", "PySide6", "qtpy")
"""Versions named in a report, of those loaded."""


def is_crash(error: BaseException) -> bool:
    """Whether ``error`` is unexpected (a bug, reported) rather than the user's (said in words).

    The user's: a :class:`ValueError` (the library's way of naming a bad value: MeshError,
    SelectionError, EditFileError, ...), an :class:`OSError` (a file), a :class:`MemoryError`;
    numpy's LinAlgError, a ValueError, is a failed solve: a crash. Not an :class:`Exception`
    (KeyboardInterrupt, SystemExit): not a crash.

    Examples
    --------
    >>> from hybridedit.deform.selection import SelectionError
    >>> is_crash(SelectionError("the handle is empty")), is_crash(KeyError("roi"))
    (False, True)
    """
    if not isinstance(error, Exception):
        return False
    return isinstance(error, np.linalg.LinAlgError) or not isinstance(error, _SAID)


def describe(error: BaseException, *, named: bool = True, limit: int = 160) -> str:
    """``"Type: message"`` (``named`` False: the message alone), its first line, at most ``limit``
    characters; the type alone for an error without a message. Never raises.

    Examples
    --------
    >>> describe(KeyError("roi"))
    "KeyError: 'roi'"
    >>> describe(RuntimeError("")), describe(ValueError("a\\nb"), named=False)
    ('RuntimeError', 'a')
    """
    name = type(error).__name__
    try:
        lines = str(error).strip().splitlines()
    except Exception:  # noqa: BLE001 -- an error whose message itself fails
        lines = ["(its message could not be read)"]
    text = lines[0] if lines else ""
    said = (f"{name}: {text}" if named else text) if text else name
    return said if len(said) <= limit else said[: limit - 1] + "…"


def failure_message(what: str, error: BaseException, report: Path | None, *, kept: str | None = None) -> str:
    """The one line the window shows for an unexpected error.

    Parameters
    ----------
    what : what failed, as the sentence starts ("The drag frame failed").
    error : the exception.
    report : the crash report's path, or None when it could not be written.
    kept : what the window kept ("the last good pose is kept"), or None.

    Examples
    --------
    >>> failure_message("The polish failed", RuntimeError("boom"), Path("/c/r.txt"),
    ...                 kept="the settled pose is kept")
    'The polish failed (RuntimeError: boom); the settled pose is kept. Report: /c/r.txt'
    """
    text = f"{what} ({describe(error)})" + (f"; {kept}" if kept else "")
    return text + (f". Report: {report}" if report is not None else ". No crash report could be written.")


def reports_folder() -> Path:
    """``<user cache folder>/crash-reports`` (not created here)."""
    return default_cache_dir() / FOLDER


def session_details(session) -> dict[str, str]:
    """What a report says of the session on display: its shape's and cage's sizes, its file; never raises.

    Parameters
    ----------
    session : a :class:`~.session.Session`, or None (nothing is said).
    """
    if session is None:
        return {}
    out = {}
    for key, say in (
        ("shape on display", lambda s: f"{s.mesh.name or 'unnamed'}: {s.mesh.n_vertices:,} vertices, "
                                       f"{s.mesh.n_faces:,} faces"),
        ("its file", lambda s: str(s.path) if s.path is not None else None),
        ("its cage", lambda s: f"{s.editor.cage.n_vertices:,} vertices (cage size {s.cage_size})"),
        ("its selection", lambda s: f"ROI {int(np.count_nonzero(s.selection.roi))}, handle "
                                f"{int(np.count_nonzero(s.selection.handle))}, {s.selection.n_groups} group(s)"),
    ):
        try:
            value = say(session)
        except Exception as e:  # noqa: BLE001 -- a broken session is what is being reported
            value = f"unknown ({describe(e)})"
        if value is not None:
            out[key] = value
    return out


def _slug(context: str) -> str:
    """A file-name part of ``context``: "build of creature.ply" -> "build-of-creature-ply"."""
    return re.sub(r"[^a-z0-9]+", "-", context.lower()).strip("-")[:40].strip("-") or "error"


def _report_text(error: BaseException, context: str, details: dict | None, when: datetime.datetime) -> str:
    versions = ", ".join(f"{m} {getattr(sys.modules[m], '__version__', '?')}" for m in _LIBRARIES
                         if m in sys.modules)
    lines = [
        "hybridedit crash report",
        f"time: {when.isoformat(timespec='seconds')}",
        f"what failed: {context}",
        f"hybridedit: {__version__}",
        f"python: {platform.python_version()} ({platform.python_implementation()}) on {platform.platform()}",
    ]
    if versions:
        lines.append(f"libraries: {versions}")
    for key, value in (details or {}).items():
        lines.append(f"{key}: {value}")
    lines += ["", f"error: {describe(error, limit=2000)}", ""]
    lines += "".join(traceback.format_exception(type(error), error, error.__traceback__)).rstrip().splitlines()
    return "\n".join(lines) + "\n"


def _prune(folder: Path, keep: int) -> None:
    """Remove all but the newest ``keep`` reports of ours (their names sort by time)."""
    ours = sorted(p for p in folder.iterdir() if _NAME.match(p.name) and p.is_file())
    for old in ours[: max(len(ours) - keep, 0)]:
        try:
            old.unlink()
        except OSError:
            pass


def write_crash_report(error: BaseException, *, context: str, folder: Path | None = None,
                       details: dict | None = None) -> Path | None:
    """Write a crash report for ``error``; return its path, or None when it could not be written.

    The report (UTF-8 text, written atomically) says when, what failed (``context``), the
    hybridedit, Python and platform versions, ``details`` one per line, and the traceback.
    It goes to ``folder/<date>-<time>-<microseconds>-<context slug>.txt``; all but the newest
    :data:`KEEP` reports there are removed. Never raises (an :class:`Exception`): the caller
    says the error whether or not its report was written.

    Parameters
    ----------
    error : the exception, with its ``__traceback__`` (as caught, or handed over by a thread).
    context : what failed, in words ("drag frame", "polish", "build of creature.ply").
    folder : where to write; default ``<user cache folder>/crash-reports`` (:func:`reports_folder`).
    details : more to say, ``{name: value}`` (e.g. :func:`session_details`).

    Returns
    -------
    Path or None
        The report written.

    Examples
    --------
    >>> import shutil, tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> try:
    ...     1 / 0
    ... except ZeroDivisionError as e:
    ...     path = write_crash_report(e, context="drag frame", folder=folder, details={"cage": "150 vertices"})
    >>> path.parent == folder, path.name.endswith("-drag-frame.txt")
    (True, True)
    >>> text = path.read_text()
    >>> "Traceback (most recent call last)" in text and "ZeroDivisionError: division by zero" in text
    True
    >>> shutil.rmtree(folder)
    """
    try:
        folder = Path(folder) if folder is not None else reports_folder()
        folder.mkdir(parents=True, exist_ok=True)
        when = datetime.datetime.now().astimezone()
        path = folder / f"{when:%Y%m%d-%H%M%S-%f}-{_slug(context)}.txt"
        while path.exists():  # (two reports in one microsecond: the second one's time moves on by one)
            when += datetime.timedelta(microseconds=1)
            path = folder / f"{when:%Y%m%d-%H%M%S-%f}-{_slug(context)}.txt"
        text = _report_text(error, context, details, when)
        with atomic_write(path, "w") as f:
            f.write(text)
        _prune(folder, KEEP)
        return path
    except Exception:  # noqa: BLE001 -- a report that cannot be written must not hide the error itself
        return None
