"""The package's front door: names, import orders, and the lossless open / pose / save path."""

from __future__ import annotations

import json
import pkgutil
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import hybridedit as he

from shapes import SHARED_MESHES

SPOT = SHARED_MESHES / "spot"


def run_python(code: str) -> dict:
    """Run ``code`` in a fresh interpreter; it prints one JSON object, returned here."""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.strip().splitlines()[-1])


CHECK_NAMES = """
import json, hybridedit.deform.propagate, hybridedit.fileio.editfile
print(json.dumps({
    "function": he.propagate_positions is hybridedit.deform.propagate.propagate,
    "handle_edit": he.HandleEdit is hybridedit.fileio.editfile.HandleEdit,
    "editor": he.HybridEditor is hybridedit.deform.editor.HybridEditor,
    "no_module_name": not hasattr(he, "propagate"),
}))
"""


@pytest.mark.slow
@pytest.mark.parametrize("first", ["package", "engine"])
def test_every_name_is_the_same_object_in_every_import_order(first: str) -> None:
    """A name of the package is its module's object whether the package's names or the engine's
    modules are imported first (no package name is also a submodule, which the import system would
    rebind)."""
    if first == "package":  # the package's names first, the engine imported afterwards
        head = ("import sys, hybridedit as he\nfrom hybridedit import HandleEdit, propagate_positions\n"
                "import hybridedit.deform.editor\n")
    else:  # the engine first (as any script that built an editor)
        head = "import sys, hybridedit.deform.editor\nimport hybridedit as he\n"
    assert run_python(head + CHECK_NAMES) == {"function": True, "handle_edit": True, "editor": True,
                                              "no_module_name": True}


def test_the_exported_names() -> None:
    from hybridedit.fileio import editfile

    assert "HandleEdit" in he.__all__ and he.HandleEdit is editfile.HandleEdit
    for name in he.__all__:
        assert getattr(he, name) is not None, name
    submodules = {m.name for m in pkgutil.iter_modules(he.__path__)}
    assert not submodules & set(he.__all__), "a package name that is also a submodule changes with imports"
    assert "open" not in he.__all__ and callable(he.open)  # star imports keep the builtin open
    from hybridedit.batching import api

    assert "batch" in he.__all__ and he.batch is api.batch  # the function, not a package (hybridedit.batching)
    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        he.nothing_here  # noqa: B018


@pytest.fixture
def spot(tmp_path: Path) -> Path:
    """spot's quad mesh with a material library and its texture, in a folder of their own."""
    if not (SPOT / "spot_quadrangulated.obj").exists():
        pytest.skip(f"{SPOT} not available")
    src = tmp_path / "in"
    src.mkdir()
    lines = (SPOT / "spot_quadrangulated.obj").read_bytes().splitlines(keepends=True)
    first_f = next(i for i, line in enumerate(lines) if line.startswith(b"f "))
    lines[first_f:first_f] = [b"o spot\n", b"usemtl spot_material\n", b"s 1\n"]
    (src / "spot.obj").write_bytes(b"mtllib spot.mtl\n" + b"".join(lines))
    (src / "spot.mtl").write_text("newmtl spot_material\nKd 1 1 1\nmap_Kd textures/spot_texture.png\n")
    (src / "textures").mkdir()
    shutil.copy(SPOT / "spot_texture.png", src / "textures" / "spot_texture.png")
    return src / "spot.obj"


def test_open_pose_save_keeps_everything_spot_has(spot: Path, tmp_path: Path) -> None:
    ed = he.open(spot, 150, cache=False)
    assert ed.document is not None and ed.document.extras["texture coordinates"] == 3225
    v = ed.mesh.vertices
    z = v[:, 2]
    ed.set_selection(np.flatnonzero(z > z.max() - 0.15), roi=np.flatnonzero(z > z.max() - 0.5))
    P = ed.pose(translate=(0.0, 0.2, 0.05))
    moved = np.any(P != v, axis=1)
    assert 0 < moved.sum() < len(v)

    out = tmp_path / "out" / "spot_posed.obj"
    out.parent.mkdir()
    assert ed.save(out) == []
    before, after = spot.read_bytes().splitlines(), out.read_bytes().splitlines()
    assert [s for s in after if not s.startswith(b"v ")] == [s for s in before if not s.startswith(b"v ")]
    assert sum(s.startswith(b"vt ") for s in after) == 3225 and b"mtllib spot.mtl" in after
    assert all(len(s.split()) == 5 for s in after if s.startswith(b"f "))  # quads stay quads
    back = he.read_document(out)
    # the pose, to the file's own precision (spot: 6 significant digits), within half a unit of the last digit
    assert np.all(np.abs(back.mesh.vertices - P) <= 0.5e-5 * np.abs(P) + 1e-300)
    v_before = [s for s in before if s.startswith(b"v ")]
    v_after = [s for s in after if s.startswith(b"v ")]
    assert all(a == b for a, b, m in zip(v_after, v_before, moved) if not m)  # unmoved lines as written
    assert (out.parent / "spot.mtl").read_bytes() == (spot.parent / "spot.mtl").read_bytes()
    assert (out.parent / "textures" / "spot_texture.png").read_bytes() == (SPOT / "spot_texture.png").read_bytes()


def test_open_passes_build_and_editor_options(spot: Path) -> None:
    said = []
    ed = he.HybridEditor.from_file(spot, 80, truncation=0.05, iterations=3, propagation="linear",
                                   progress=lambda stage, fraction: said.append(stage))
    assert abs(ed.cage.n_vertices - 80) <= 6 and ed.truncation == 0.05
    assert ed.iterations == 3 and ed.propagation == "linear"
    assert any(s.startswith("reading spot.obj") for s in said) and len(set(said)) > 1
    with pytest.raises(he.MeshFileError, match="missing.obj"):
        he.open(spot.parent / "missing.obj")


@pytest.mark.parametrize("text, number", [("0.05", 0.05), ("5%", 0.05), ("80", 80), (" 80 ", 80)])
def test_open_takes_a_cage_size_written_as_the_command_line_takes_it(spot: Path, text: str, number) -> None:
    """A cage size from a config file or a form ("0.05", "5%", "80") is the number it says: the same cage,
    from the same cache entry, as that number."""
    a, b = he.open(spot, cage_size=text, cache=False), he.open(spot, cage_size=number, cache=False)
    assert a.rig.cage_size == number and type(a.rig.cage_size) is type(number)
    assert np.array_equal(a.cage.vertices, b.cage.vertices)
    from hybridedit.binding.cache import cache_key
    from hybridedit.defaults import check_cage_size

    assert cache_key(a.mesh, check_cage_size(text), 0.03) == cache_key(a.mesh, number, 0.03)


@pytest.mark.parametrize("bad", ["lots", "0", "150%", "", [0.05], None, True])
def test_open_refuses_another_cage_size_naming_it_and_the_forms(spot: Path, bad) -> None:
    with pytest.raises(ValueError, match=r"cage_size must be a vertex count \(2000\), a fraction .* or a "
                                         r"percentage \('5%'\), got"):
        he.open(spot, cage_size=bad, cache=False)
