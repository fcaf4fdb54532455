"""What the browser's Save may write: inside the mesh's folder only, never the mesh itself."""

from __future__ import annotations

import os

import pytest

from hybridedit.web.server_files import OutputPathError, posed_name, save_target


def test_save_writes_only_inside_the_meshs_folder(tmp_path):
    mesh = tmp_path / "scans" / "creature.ply"
    mesh.parent.mkdir()
    mesh.write_bytes(b"")
    (mesh.parent / "poses").mkdir()
    assert posed_name(mesh) == "creature-posed.ply"
    assert save_target(mesh, "creature-posed.ply") == mesh.parent.resolve() / "creature-posed.ply"
    assert save_target(mesh, " poses/a.obj ") == mesh.parent.resolve() / "poses" / "a.obj"
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    (mesh.parent / "out").symlink_to(outside)
    for typed, said in [("../x.ply", "not in the mesh's folder"), (str(outside / "x.ply"), "not in the mesh's folder"),
                        ("out/x.ply", "not in the mesh's folder"), ("", "give a file name"),
                        ("creature.ply", "refusing to overwrite"), ("x.txt", "x.txt"),
                        ("missing/x.ply", "does not exist")]:
        with pytest.raises(OutputPathError, match=said):
            save_target(mesh, typed)
    assert not os.listdir(outside)
