"""The example scripts in examples/ run end to end on a small generated shape.

Each example runs as its own process with the venv's Python, as a user would
run it, with DISPLAY unset (the render example must find a way to render by
itself), its outputs going to tmp_path. The examples open, pose and save through
the lossless path: an OBJ with texture coordinates and quads comes back whole.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hybridedit.fileio.editfile import load_edit
from hybridedit.fileio.meshfiles import read_mesh, write_mesh

from shapes import SHARED_MESHES, bumpy_blob

# slow: each example is a process of its own that imports the engine, builds a cage and binds
pytestmark = pytest.mark.slow

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
CAGE = "100"


@pytest.fixture(scope="module")
def blob_ply(tmp_path_factory) -> Path:
    """A bumpy capsule about 4 long along X, 2,562 vertices, as a binary PLY."""
    path = tmp_path_factory.mktemp("example-mesh") / "blob.ply"
    write_mesh(path, bumpy_blob(4))
    return path


def run_example(name: str, *args: str, cwd: Path) -> str:
    """Run examples/<name> with no DISPLAY; return its stdout (fail with its output)."""
    env = {k: v for k, v in os.environ.items() if k != "DISPLAY"}
    done = subprocess.run(
        [sys.executable, str(EXAMPLES / name), *args], cwd=cwd, env=env,
        capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 0, f"{name} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}"
    return done.stdout


def hand_mean(vertices: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """Mean position of the vertices in the last 8% along +X of the rest shape."""
    lo, hi = rest.min(axis=0), rest.max(axis=0)
    return vertices[(rest[:, 0] - lo[0]) / (hi[0] - lo[0]) > 0.92].mean(axis=0)


def assert_arm_raised(result: Path, rest_path: Path, fraction: float = 0.05) -> None:
    rest, posed = read_mesh(rest_path), read_mesh(result)
    assert posed.n_faces == rest.n_faces and posed.n_vertices == rest.n_vertices
    assert np.array_equal(posed.faces, rest.faces)
    assert np.all(np.isfinite(posed.vertices))
    lift = hand_mean(posed.vertices, rest.vertices)[1] - hand_mean(rest.vertices, rest.vertices)[1]
    assert lift > fraction * rest.bbox_diagonal(), f"the +X end rose by only {lift:.3g}"


def assert_picture(png: Path, min_size: tuple[int, int]) -> None:
    import matplotlib.image

    assert png.is_file()
    img = matplotlib.image.imread(png)[..., :3]
    assert img.shape[1] >= min_size[0] and img.shape[0] >= min_size[1]
    colours = np.unique((img.reshape(-1, 3) * 255).round().astype(np.uint8), axis=0)
    assert len(colours) > 50, f"{png.name} looks blank ({len(colours)} colours)"
    background = np.all(img > 0.98, axis=2).mean()  # both examples draw on white
    assert background < 0.97, f"{png.name} is {background:.0%} white"


def test_scripted_edit(blob_ply: Path, tmp_path: Path) -> None:
    out = run_example("scripted_edit.py", str(blob_ply), "--out", str(tmp_path / "o"), "--cage", CAGE,
                      cwd=tmp_path)
    assert_arm_raised(tmp_path / "o" / "blob_raised.ply", blob_ply)
    assert "RRMS edge error" in out and "frame median" in out


def test_batch_replay(blob_ply: Path, tmp_path: Path) -> None:
    out = run_example("batch_replay.py", str(blob_ply), "--out", str(tmp_path), "--cage", CAGE,
                      "--frames", "10", cwd=tmp_path)
    edit = load_edit(tmp_path / "arm_edit.json")
    assert edit.handle.size and edit.roi is not None and edit.rotate is not None
    stats = json.loads((tmp_path / "stats.json").read_text())
    for key in ("n_vertices", "n_faces", "cage_vertices", "bind_seconds", "frames", "frame_ms_median",
                "rrms_edge_error_percent", "max_stretch_percent", "total_seconds"):
        assert key in stats, key
    assert stats["n_vertices"] == 2562 and stats["frames"] == 10
    assert 0 < stats["rrms_edge_error_percent"] < 50
    assert '"rrms_edge_error_percent"' in out  # the stats were printed
    assert_arm_raised(tmp_path / "blob_replayed.ply", blob_ply)


@pytest.fixture
def spot_obj(tmp_path: Path) -> Path:
    """spot's quad mesh with texture coordinates, a material library and its texture, lying along X."""
    src = SHARED_MESHES / "spot"
    if not (src / "spot_quadrangulated.obj").exists():
        pytest.skip(f"{src} not available")
    folder = tmp_path / "spot"
    (folder / "textures").mkdir(parents=True)
    lines = (src / "spot_quadrangulated.obj").read_bytes().splitlines(keepends=True)
    first_f = next(i for i, line in enumerate(lines) if line.startswith(b"f "))
    lines[first_f:first_f] = [b"usemtl spot_material\n"]
    (folder / "spot.obj").write_bytes(b"mtllib spot.mtl\n" + b"".join(lines))
    (folder / "spot.mtl").write_text("newmtl spot_material\nmap_Kd textures/spot_texture.png\n")
    shutil.copy(src / "spot_texture.png", folder / "textures" / "spot_texture.png")
    return folder / "spot.obj"


def non_vertex_lines(path: Path) -> list[bytes]:
    return [line for line in path.read_bytes().splitlines() if not line.startswith(b"v ")]


def test_scripted_edit_keeps_texture_coordinates_quads_and_materials(spot_obj: Path, tmp_path: Path) -> None:
    out = run_example("scripted_edit.py", str(spot_obj), "--out", str(tmp_path / "o"), "--cage", CAGE,
                      "--no-cache", cwd=tmp_path)
    result = tmp_path / "o" / "spot_raised.obj"
    assert non_vertex_lines(result) == non_vertex_lines(spot_obj)  # vt, quads with v/vt, mtllib, usemtl
    assert (tmp_path / "o" / "spot.mtl").is_file() and (tmp_path / "o" / "textures" / "spot_texture.png").is_file()
    assert_arm_raised(result, spot_obj, 0.01)  # (spot is short along X: its side, not an arm)
    assert "note:" not in out


def test_render_before_after_saves_the_whole_file(spot_obj: Path, tmp_path: Path) -> None:
    run_example("render_before_after.py", str(spot_obj), "--out", str(tmp_path), "--cage", CAGE,
                "--size", "400", "200", "--save", str(tmp_path / "posed.obj"), cwd=tmp_path)
    assert non_vertex_lines(tmp_path / "posed.obj") == non_vertex_lines(spot_obj)
    assert_arm_raised(tmp_path / "posed.obj", spot_obj, 0.01)


def test_cage_sizes(blob_ply: Path, tmp_path: Path) -> None:
    out = run_example("cage_sizes.py", str(blob_ply), "--out", str(tmp_path), "--cage", "60", "0.04", "150",
                      "--tolerance", "1e-4", cwd=tmp_path)
    assert_picture(tmp_path / "cage_sizes.png", (1000, 300))
    table = [line.split() for line in out.splitlines() if line.split() and line.split()[0].isdigit()]
    assert len(table) == 3  # one row a size, smallest first
    sizes = [int(row[0]) for row in table]
    assert sizes == sorted(sizes) and len(set(sizes)) == 3


def test_render_before_after(blob_ply: Path, tmp_path: Path) -> None:
    out = run_example("render_before_after.py", str(blob_ply), "--out", str(tmp_path), "--cage", CAGE,
                      "--size", "800", "400", cwd=tmp_path)
    assert_picture(tmp_path / "before_after.png", (800, 400))
    assert "wrote" in out


def test_outputs_default_to_the_current_folder(blob_ply: Path, tmp_path: Path) -> None:
    run_example("scripted_edit.py", str(blob_ply), "--cage", CAGE, "--tolerance", "1e-3", cwd=tmp_path)
    assert (tmp_path / "blob_raised.ply").is_file()
