"""Every output path is refused before any work starts, with a message naming it."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hybridedit import cli

from hybridedit.fileio import atomic

from hybridedit.fileio import outpaths
from hybridedit.fileio.meshfiles import write_mesh

from shapes import bumpy_blob


@pytest.fixture
def files(tmp_path: Path) -> dict[str, Path]:
    mesh = tmp_path / "in.obj"
    write_mesh(mesh, bumpy_blob(1))
    edit = tmp_path / "edit.json"
    edit.write_text(json.dumps({"handle": [0], "translate": [0, 0.1, 0]}))
    return {"mesh": mesh, "edit": edit, "dir": tmp_path}


@pytest.fixture
def no_work(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Reading the edit or the mesh means the work started: each such call is recorded (and fails)."""
    started: list[str] = []

    def reader(name: str):
        def read(*args, **kwargs):
            started.append(name)
            raise AssertionError("the work started before the output paths were checked")

        return read

    monkeypatch.setattr(cli, "read_document", reader("read_document"))
    monkeypatch.setattr(cli, "load_edit", reader("load_edit"))
    return started


def refused(argv: list[str], capsys: pytest.CaptureFixture, no_work: list[str]) -> str:
    """The one error line of a run refused before it read the edit or the mesh."""
    rc = cli.main(argv)
    err = capsys.readouterr().err
    assert no_work == [], f"read {no_work} before refusing"
    assert rc == 2, err
    assert err.startswith("hybridedit: error: ") and err.count("\n") == 1
    return err


def deform(files, out, *extra) -> list[str]:
    return ["deform", str(files["mesh"]), "-o", str(out), "--edit", str(files["edit"]), "-q", *extra]


def test_unknown_output_extension(files, no_work, capsys) -> None:
    err = refused(deform(files, files["dir"] / "out.xyz"), capsys, no_work)
    assert "out.xyz: -o has unknown extension '.xyz' (use .obj, .off, .ply, .stl, .glb)" in err
    err = refused(deform(files, files["dir"] / "out"), capsys, no_work)
    assert "-o has no extension" in err


def test_stats_must_be_json(files, no_work, capsys) -> None:
    err = refused(deform(files, files["dir"] / "out.obj", "--stats", str(files["dir"] / "s.obj")), capsys, no_work)
    assert "s.obj: --stats has unknown extension '.obj' (use .json)" in err


def test_missing_folder_and_non_folder(files, no_work, capsys) -> None:
    err = refused(deform(files, files["dir"] / "nowhere" / "out.obj"), capsys, no_work)
    assert "-o folder" in err and "nowhere does not exist" in err
    stats = files["dir"] / "no" / "s.json"
    err = refused(deform(files, files["dir"] / "out.obj", "--stats", str(stats)), capsys, no_work)
    assert "--stats folder" in err and "does not exist" in err
    err = refused(deform(files, files["mesh"] / "out.obj"), capsys, no_work)
    assert "is not a folder" in err


def test_output_is_a_folder(files, no_work, capsys) -> None:
    (files["dir"] / "dir.ply").mkdir()
    assert "-o is a folder" in refused(deform(files, files["dir"] / "dir.ply"), capsys, no_work)


def test_read_only_folder(files, no_work, capsys, monkeypatch) -> None:
    """chmod does not stop root, so answer os.access as a read-only folder would."""
    real = os.access
    monkeypatch.setattr(outpaths.os, "access",
                        lambda p, mode: False if Path(p) == files["dir"] else real(p, mode))
    assert "is not writable" in refused(deform(files, files["dir"] / "out.obj"), capsys, no_work)


def test_output_is_the_input(files, no_work, capsys) -> None:
    err = refused(deform(files, files["mesh"]), capsys, no_work)
    assert "refusing to overwrite the input file with -o (use --force)" in err
    odd = files["dir"] / "sub" / ".." / "in.obj"
    (files["dir"] / "sub").mkdir()
    assert "refusing to overwrite the input" in refused(deform(files, odd), capsys, no_work)
    link = files["dir"] / "link.obj"
    link.symlink_to(files["mesh"])
    assert "refusing to overwrite the input" in refused(deform(files, link), capsys, no_work)
    hard = files["dir"] / "hard.obj"
    os.link(files["mesh"], hard)
    assert "refusing to overwrite the input" in refused(deform(files, hard), capsys, no_work)


def test_stats_onto_an_input_or_the_output(files, no_work, capsys) -> None:
    err = refused(deform(files, files["dir"] / "out.obj", "--stats", str(files["edit"])), capsys, no_work)
    assert "refusing to overwrite the edit file with --stats" in err
    alias = files["dir"] / "alias.json"
    alias.symlink_to(files["dir"] / "out.obj")
    err = refused(deform(files, files["dir"] / "out.obj", "--stats", str(alias)), capsys, no_work)
    assert "-o and --stats are the same file" in err


def test_force_allows_only_the_mesh_onto_the_input(files, capsys) -> None:
    before = files["mesh"].read_bytes()
    assert cli.main(deform(files, files["mesh"], "--cage", "40", "--frames", "1", "--force")) == 0
    assert files["mesh"].read_bytes() != before


def test_check_outputs_accepts_good_paths_and_refuses_the_same_ones_gone_wrong(tmp_path: Path) -> None:
    good = {"-o": (tmp_path / "a.obj", (".obj",)), "--stats": (tmp_path / "a.json", (".json",)),
            "--other": (None, (".x",))}
    outputs_before = sorted(tmp_path.iterdir())
    assert outpaths.check_outputs(good, inputs={"input": tmp_path / "in.obj"}) is None
    assert sorted(tmp_path.iterdir()) == outputs_before  # a check writes nothing
    for bad, words in (({**good, "-o": (tmp_path / "a.txt", (".obj",))}, ".txt"),
                       ({**good, "--stats": (tmp_path / "a.obj", (".obj",))}, "same file"),
                       ({**good, "-o": (tmp_path / "in.obj", (".obj",))}, "input")):
        with pytest.raises(outpaths.OutputPathError, match=words):
            outpaths.check_outputs(bad, inputs={"input": tmp_path / "in.obj"})


def test_stale_temporaries_of_ours_are_removed_by_the_next_write(tmp_path: Path) -> None:
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    stale = tmp_path / f".out.obj.hybridedit-{dead.pid}-abcdefgh.tmp"
    live = tmp_path / f".out.obj.hybridedit-{os.getpid()}-abcdefgh.tmp"
    # another program's temporaries, named as Python's tempfile names them (two hours old), are never ours
    notes = tmp_path / ".notes.abcd1234.tmp"
    out_like = tmp_path / ".out.obj.k2j4h5g6.tmp"
    someone_elses = tmp_path / ".notes.tmp"
    for p in (stale, live, notes, out_like, someone_elses):
        p.write_bytes(b"x" * 100)
    for p in (notes, out_like):
        os.utime(p, (time.time() - 7200, time.time() - 7200))
    write_mesh(tmp_path / "new.ply", bumpy_blob(0))
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted([live.name, notes.name, out_like.name, someone_elses.name, "new.ply"])
    assert notes.read_bytes() == b"x" * 100  # intact
    assert atomic.remove_stale_temporaries(tmp_path / "missing") == []
