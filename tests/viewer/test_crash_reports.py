"""Crash reports (hybridedit.viewer.model.crash_reports), Qt-free: what a report holds, where it goes,
the newest kept, a report that cannot be written, and which errors are crashes at all."""

from __future__ import annotations

import os
import platform
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import hybridedit
from hybridedit.core.mesh import MeshError
from hybridedit.deform.selection import SelectionError
from hybridedit.fileio.atomic import WriteError
from hybridedit.fileio.editfile import EditFileError
from hybridedit.viewer.model import crash_reports as cr


def raised(error: BaseException) -> BaseException:
    """``error`` as an except clause catches it: with its traceback."""
    def inner():
        raise error

    try:
        inner()
    except BaseException as e:  # noqa: BLE001
        return e
    raise AssertionError("not raised")


def test_a_report_holds_when_what_failed_the_versions_the_details_and_the_traceback(tmp_path):
    e = raised(RuntimeError("the solve went wrong"))
    path = cr.write_crash_report(e, context="build of creature.ply", folder=tmp_path,
                                 details={"its cage": "5,028 vertices"})
    assert path.parent == tmp_path
    assert path.name.endswith("-build-of-creature-ply.txt") and cr._NAME.match(path.name)
    text = path.read_text(encoding="utf-8")
    assert "what failed: build of creature.ply" in text
    assert f"hybridedit: {hybridedit.__version__}" in text
    assert f"python: {platform.python_version()}" in text and "numpy " in text
    assert "its cage: 5,028 vertices" in text
    assert "error: RuntimeError: the solve went wrong" in text
    # the traceback, down to the line that raised
    tb = text[text.index("Traceback (most recent call last)"):]
    assert "in inner" in tb and "raise error" in tb and tb.rstrip().endswith("RuntimeError: the solve went wrong")
    # written atomically: no temporary left beside it
    assert [p.name for p in tmp_path.iterdir()] == [path.name]


def test_the_default_folder_is_in_the_user_cache_folder(tmp_path, monkeypatch):
    monkeypatch.setenv("HYBRIDEDIT_CACHE_DIR", str(tmp_path / "cache"))
    path = cr.write_crash_report(raised(KeyError("roi")), context="polish")
    assert path.parent == tmp_path / "cache" / "crash-reports" == cr.reports_folder()
    assert path.name.endswith("-polish.txt")


def test_two_reports_in_a_row_are_two_files(tmp_path):
    e = raised(IndexError("x"))
    paths = [cr.write_crash_report(e, context="drag frame", folder=tmp_path) for _ in range(5)]
    assert len(set(paths)) == 5 and all(p.exists() for p in paths)
    assert sorted(paths) == paths  # (their names sort by time: the pruning keeps the newest)


def test_only_the_newest_reports_are_kept_and_nothing_else_is_touched(tmp_path):
    old = [tmp_path / f"20200101-0000{k:02d}-000000-drag-frame.txt" for k in range(cr.KEEP + 5)]
    for p in old:
        p.write_text("old report")
    mine = tmp_path / "notes.txt"  # not a report: stays
    mine.write_text("mine")
    new = cr.write_crash_report(raised(RuntimeError("now")), context="settle", folder=tmp_path)
    reports = sorted(p for p in tmp_path.iterdir() if cr._NAME.match(p.name))
    assert len(reports) == cr.KEEP and reports[-1] == new
    assert reports[:-1] == old[-(cr.KEEP - 1):]  # the oldest went
    assert mine.read_text() == "mine"


def test_a_report_that_cannot_be_written_returns_none_and_raises_nothing(tmp_path):
    blocked = tmp_path / "a file"
    blocked.write_text("")
    assert cr.write_crash_report(raised(RuntimeError("x")), context="polish", folder=blocked) is None
    if os.geteuid() != 0:  # (root writes anywhere)
        ro = tmp_path / "read-only"
        ro.mkdir()
        ro.chmod(0o500)
        try:
            assert cr.write_crash_report(raised(RuntimeError("x")), context="polish", folder=ro) is None
        finally:
            ro.chmod(0o700)
    # nor does an error whose message itself fails: its report is written all the same
    class Unprintable(Exception):
        def __str__(self):
            raise TypeError("no message")

    e = raised(Unprintable())
    path = cr.write_crash_report(e, context="drag frame", folder=tmp_path)
    assert path is not None and "Unprintable" in path.read_text()
    assert cr.describe(e) == "Unprintable: (its message could not be read)"
    assert cr.failure_message("The polish failed", e, None) == (
        "The polish failed (Unprintable: (its message could not be read)). No crash report could be written.")


def test_the_users_errors_are_said_not_reported():
    for said in (MeshError("bad.obj: no faces"), SelectionError("the handle is empty"), EditFileError("x"),
                 WriteError("/x", "no space left on device"), ValueError("cage size 0"), MemoryError(),
                 FileNotFoundError("x"), KeyboardInterrupt()):
        assert not cr.is_crash(said), said
    for crash in (RuntimeError("x"), KeyError("x"), IndexError("x"), TypeError("x"), AttributeError("x"),
                  ZeroDivisionError("x"), AssertionError(), np.linalg.LinAlgError("singular matrix")):
        assert cr.is_crash(crash), crash


def test_the_message_names_what_failed_what_was_kept_and_the_report():
    e = RuntimeError("boom\nsecond line")
    msg = cr.failure_message("The drag frame failed", e, Path("/c/crash-reports/r.txt"),
                             kept="the drag was undone and the last good pose kept")
    assert msg == ("The drag frame failed (RuntimeError: boom); the drag was undone and the last good pose kept. "
                   "Report: /c/crash-reports/r.txt")
    assert len(cr.describe(RuntimeError("x" * 1000))) == 160


def test_session_details_say_the_shape_and_cage_and_survive_a_broken_session():
    good = SimpleNamespace(mesh=SimpleNamespace(name="blob", n_vertices=2562, n_faces=5120), path=None,
                           editor=SimpleNamespace(cage=SimpleNamespace(n_vertices=150)), cage_size=150,
                           selection=SimpleNamespace(roi=np.ones(150, bool), handle=np.zeros(150, bool), n_groups=1))
    d = cr.session_details(good)
    assert d == {"shape on display": "blob: 2,562 vertices, 5,120 faces",
                 "its cage": "150 vertices (cage size 150)", "its selection": "ROI 150, handle 0, 1 group(s)"}
    broken = SimpleNamespace(mesh=good.mesh, path=Path("/m/blob.obj"), cage_size=0.05)
    d = cr.session_details(broken)
    assert d["its file"] == "/m/blob.obj" and d["its cage"].startswith("unknown (AttributeError")
    assert cr.session_details(None) == {}


@pytest.mark.parametrize("context, slug", [("drag frame", "drag-frame"),
                                           ("Build of Creature.PLY", "build-of-creature-ply"),
                                           ("???", "error"), ("x" * 80, "x" * 40)])
def test_the_file_name_slug(context, slug):
    assert cr._slug(context) == slug
