"""An editor and its mesh file: he.open / HybridEditor.from_file and save (hybridedit.deform.editor_files)."""

from pathlib import Path

import numpy as np
import pytest

import hybridedit as he
from hybridedit import HybridEditor

from shapes import arm_edit




def test_save_without_a_document_writes_positions_and_faces_with_a_note(blob_rig, blob, tmp_path):
    from hybridedit.fileio.meshfiles import read_mesh

    ed = HybridEditor(blob_rig)
    assert ed.document is None
    P = ed.pose(**arm_edit(ed, blob))
    notes = ed.save(tmp_path / "posed.ply")
    assert len(notes) == 1 and "no source document" in notes[0]
    back = read_mesh(tmp_path / "posed.ply")
    assert np.array_equal(back.vertices, P) and np.array_equal(back.faces, blob.faces)


def _blob_obj(blob, path: Path) -> Path:
    """``blob`` as an OBJ with things besides positions and triangles: a comment, an object name,
    texture coordinates and faces that use them."""
    lines = ["# a blob with texture coordinates", "o blob"]
    lines += [f"v {x!r} {y!r} {z!r}" for x, y, z in blob.vertices.tolist()]
    lines += [f"vt {i / blob.n_vertices!r} 0.5" for i in range(blob.n_vertices)]
    lines += ["f " + " ".join(f"{v + 1}/{v + 1}" for v in f) for f in blob.faces.tolist()]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_open_pose_save_keeps_what_the_file_holds(blob, tmp_path):
    src = _blob_obj(blob, tmp_path / "blob.obj")
    said = []
    ed = he.open(src, 300, cache=False, iterations=3, propagation="linear",
                 progress=lambda stage, fraction: said.append(stage))
    assert ed.iterations == 3 and ed.propagation == "linear" and abs(ed.cage.n_vertices - 300) <= 6
    assert any(s.startswith("reading blob.obj") for s in said) and len(set(said)) > 1
    assert ed.document is not None and ed.document.extras["texture coordinates"] == blob.n_vertices
    P = ed.pose(**arm_edit(ed, blob))
    out = tmp_path / "posed.obj"
    assert ed.save(out) == []
    before, after = src.read_bytes().splitlines(), out.read_bytes().splitlines()
    assert [s for s in after if not s.startswith(b"v ")] == [s for s in before if not s.startswith(b"v ")]
    back = he.read_mesh(out)
    assert np.allclose(back.vertices, P, rtol=0, atol=1e-12) and np.array_equal(back.faces, blob.faces)
    with pytest.raises(he.MeshFileError, match="missing.obj"):
        HybridEditor.from_file(tmp_path / "missing.obj")
