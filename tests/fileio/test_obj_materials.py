"""The files beside an OBJ: material libraries and their images."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hybridedit.fileio.document import Material
from hybridedit.fileio.formats.obj_materials import companions, image_names, read_mtl, same_content
from hybridedit.fileio.meshfiles import read_document

PNG = b"\x89PNG\r\n\x1a\n" + bytes(range(32))


def test_read_mtl_takes_colour_opacity_and_the_diffuse_image(tmp_path):
    (tmp_path / "skin.png").write_bytes(PNG)
    (tmp_path / "a.mtl").write_text("newmtl skin\nKd 0.5 0.25 1\nd 0.75\nmap_Kd skin.png\n"
                                    "newmtl glass\nTr 0.9\nmap_Kd missing.png\n")
    lib = read_mtl(tmp_path / "a.mtl")
    assert lib["skin"].color == (0.5, 0.25, 1.0, 0.75) and lib["skin"].image == PNG
    assert np.isclose(lib["glass"].color[3], 0.1) and lib["glass"].image is None
    assert read_mtl(tmp_path / "none.mtl") == {}


def test_image_names_are_distinct_plain_file_names():
    a, b, c = Material("a"), Material("b"), Material("c")
    a.image, a.image_name = PNG, "dir\\skin.png"
    b.image, b.image_name = PNG, "skin.png"
    assert image_names([a, b, c]) == ["skin.png", "1_skin.png", None]


def test_companions_travel_to_another_folder_and_outside_references_are_told(tmp_path):
    src = tmp_path / "src"
    (src / "tex").mkdir(parents=True)
    (src / "tex" / "skin.png").write_bytes(PNG)
    (src / "a.mtl").write_text("newmtl skin\nmap_Kd tex/skin.png\nbump ../outside.png\n")
    (src / "m.obj").write_text("mtllib a.mtl\nmtllib ../far.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl skin\nf 1 2 3\n")
    doc = read_document(src / "m.obj")
    out = tmp_path / "out" / "m.obj"
    copies, notes = companions(doc, src / "m.obj", out)
    assert [(Path(a).name, b.relative_to(out.parent).as_posix()) for a, b in copies] == [
        ("a.mtl", "a.mtl"), ("skin.png", "tex/skin.png")]
    assert any("../far.mtl" in n for n in notes) and any("../outside.png" in n for n in notes)
    assert companions(doc, src / "m.obj", src / "again.obj") == ([], [])  # same folder: nothing to copy
    assert same_content(src / "a.mtl", src / "a.mtl") and not same_content(src / "a.mtl", tmp_path / "no")
