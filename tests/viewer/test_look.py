"""Assets look like themselves: the render mesh split at texture seams, textures and colours on screen."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import pyvista as pv

import hybridedit as he
from hybridedit.core.mesh import Mesh
from hybridedit.deform.roles import FIXED, FREE
from hybridedit.viewer.model.look import look_of
from hybridedit.core.region_metrics import ShapeMetrics
from hybridedit.viewer.render.scene import Scene
from support.window_driving import key, mouse_drag, projected, settled, to_widget

CHECKER_A = (230, 40, 40)  # red squares
CHECKER_B = (40, 60, 220)  # blue squares


def checker_png(path, squares: int = 8, size: int = 256) -> None:
    from PIL import Image

    k = size // squares
    ij = (np.arange(size) // k)
    mask = (ij[:, None] + ij[None, :]) % 2 == 0
    img = np.where(mask[..., None], np.array(CHECKER_A, np.uint8), np.array(CHECKER_B, np.uint8))
    Image.fromarray(img.astype(np.uint8)).save(path)


def uv_sphere_obj(folder, *, n_lat: int = 24, n_lon: int = 48) -> str:
    """A UV sphere with a seam (the u = 0 / u = 1 meridian: its vertices have two texture coordinates),
    quads, a material with a checker texture."""
    verts, vts, faces = [], [], []
    for i in range(n_lat + 1):
        th = np.pi * i / n_lat
        for j in range(n_lon):
            ph = 2 * np.pi * j / n_lon
            verts.append((np.sin(th) * np.cos(ph), np.cos(th), np.sin(th) * np.sin(ph)))
    for i in range(n_lat + 1):
        for j in range(n_lon + 1):
            vts.append((j / n_lon, 1.0 - i / n_lat))
    vid = lambda i, j: i * n_lon + (j % n_lon) + 1  # noqa: E731
    tid = lambda i, j: i * (n_lon + 1) + j + 1  # noqa: E731
    for i in range(n_lat):
        for j in range(n_lon):
            c = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
            faces.append(" ".join(f"{vid(a, b)}/{tid(a, b)}" for a, b in c))
    # the poles: every vertex of row 0 (and n_lat) is the same point; keep them (the reader welds nothing in OBJ)
    lines = ["mtllib ball.mtl", "usemtl checker"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in verts]
    lines += [f"vt {u:.6f} {v:.6f}" for u, v in vts]
    lines += [f"f {f}" for f in faces]
    (folder / "ball.obj").write_text("\n".join(lines) + "\n")
    (folder / "ball.mtl").write_text("newmtl checker\nKd 1 1 1\nmap_Kd checker.png\n")
    checker_png(folder / "checker.png")
    return str(folder / "ball.obj")


def render(path, mode=None, roles=None, size=(400, 400)):
    doc = he.read_document(path)
    look = look_of(doc)
    m = doc.mesh
    pl = pv.Plotter(off_screen=True, window_size=size)
    sc = Scene(pl)
    met = ShapeMetrics(m.vertices, m.faces)
    r = np.full(m.n_vertices, FREE, np.int8) if roles is None else roles
    sc.load(met, m.vertices, m.vertices[:3], np.array([[0, 1, 2]]), np.full(3, FIXED, np.int8), r, look=look, mode=mode)
    sc.reset_camera(tilted=False)
    img = np.asarray(pl.screenshot(return_img=True))[..., :3].astype(int)
    pl.close()
    return img, sc, doc


def share_near(img, colour, tol=60):
    d = np.abs(img - np.array(colour)[None, None, :]).sum(axis=2)
    return float(np.mean(d < tol))


def test_the_render_mesh_keeps_the_files_polygons_and_their_materials():
    """A triangle and a pentagon: the render triangles are the readers' fan, each with its polygon's material."""
    from hybridedit.fileio.document import Material, Texturing

    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [3, 0, 0], [3, 1, 0], [2.5, 2, 0], [2, 1, 0.0]])
    counts, flat = np.array([3, 5]), np.arange(8)
    mesh = Mesh(V, np.array([[0, 1, 2], [3, 4, 5], [3, 5, 6], [3, 6, 7]]))
    tex = Texturing(materials=[Material("a"), Material("b", color=(1, 0, 0, 1))], face_material=np.array([1, 0]))
    look = look_of(he.Document(mesh, polygons=(counts, flat), texturing=tex))
    assert look.triangles.tolist() == [[0, 1, 2], [3, 4, 5], [3, 5, 6], [3, 6, 7]]
    assert look.material.tolist() == [1, 0, 0, 0]


def test_the_render_mesh_splits_vertices_only_at_seams(tmp_path):
    path = uv_sphere_obj(tmp_path)
    doc = he.read_document(path)
    look = look_of(doc)
    n = doc.mesh.n_vertices
    assert look.default_mode == "texture" and look.has_texture
    assert np.array_equal(look.source[:n], np.arange(n))
    extra = look.source[n:]
    # the copies are the seam's vertices (u = 0 and u = 1 meet there) and nothing else
    x, z = doc.mesh.vertices[extra, 0], doc.mesh.vertices[extra, 2]
    assert len(extra) > 0 and np.all(np.abs(z) < 1e-6) and np.all(x >= -1e-6)
    # every triangle shows the shape's own triangle
    assert np.array_equal(np.sort(look.source[look.triangles], axis=1), np.sort(doc.mesh.faces, axis=1))
    seam_uv = look.uv[n:, 0]
    assert np.all(np.isclose(seam_uv, 1.0) | np.isclose(seam_uv, 0.0))


def test_seams_move_together_and_show_no_crease(tmp_path):
    path = uv_sphere_obj(tmp_path)
    img, sc, doc = render(path, roles=None)
    m = doc.mesh
    V = m.vertices.copy()
    moving = np.flatnonzero(V[:, 0] > -0.2)
    V[moving, 1] += 0.3 * (V[moving, 0] + 0.2) ** 2  # a bend through the seam (which lies at x > 0)
    sc.set_moving(moving)
    sc.update_shape(V)
    drawn = sc.parts.drawn_points()
    assert not np.any(np.isnan(drawn))  # every copy of a seam vertex at the same place
    assert np.allclose(drawn, V.astype(np.float32), atol=1e-6)
    normals = sc.parts.drawn_points(normals=True)
    assert not np.any(np.isnan(normals))  # the same normal on both sides of the seam: no crease
    seam = np.unique(sc.look.source[m.n_vertices:])
    assert np.all(np.abs(np.linalg.norm(normals[seam], axis=1) - 1.0) < 1e-3)
    # another look: its parts rewrite the same rows in a frame
    changed = sc.parts.changed
    assert changed is not None and len(changed) < m.n_vertices
    sc.set_look_mode("plain")
    assert sc.look_mode == "plain" and np.array_equal(sc.parts.changed, changed)


@pytest.mark.parametrize("fmt", ["obj", "glb"])
def test_a_texture_is_shown_on_the_model(tmp_path, fmt):
    path = uv_sphere_obj(tmp_path)
    if fmt == "glb":
        doc = he.read_document(path)
        out = tmp_path / "ball.glb"
        he.write_document(out, doc)
        path = str(out)
    img, sc, _ = render(path)
    assert sc.look_mode == "texture"
    a, b = share_near(img, CHECKER_A), share_near(img, CHECKER_B)
    assert a > 0.05 and b > 0.05  # both checker colours cover the sphere (about a third of the image)
    plain, _, _ = render(path, mode="plain")
    assert share_near(plain, CHECKER_A) < 0.001 and share_near(plain, CHECKER_B) < 0.001


def test_the_selection_tint_leaves_the_texture_readable(tmp_path):
    path = uv_sphere_obj(tmp_path)
    doc = he.read_document(path)
    roles = np.where(doc.mesh.vertices[:, 0] < 0.0, FIXED, FREE).astype(np.int8)  # the left half held
    img, sc, _ = render(path, roles=roles)
    h, w, _ = img.shape
    left, right = img[:, : w // 2], img[:, w // 2:]
    # both checker colours still tell apart on the held (tinted) half, as on the free half
    for half in (left, right):
        red = half[..., 0] - half[..., 2]
        assert np.mean(red > 80) > 0.03 and np.mean(red < -80) > 0.03


def test_the_tint_over_a_mid_grey_texel_stays_light(tmp_path):
    """Every role's tint on a texture, as drawn (the factor VTK multiplies the texel by), keeps at least 80%
    of each channel of a mid-grey texel: the tint multiplies, so the texture's own contrast stays, and it
    darkens or shifts a texel by at most a fifth (26 of 128 levels), less than the darkest tint's own
    distance from white; a large ROI or handle over a textured face then reads as the texture."""
    path = uv_sphere_obj(tmp_path)
    doc = he.read_document(path)
    n_groups = 8  # a whole cycle of the handle colours (palette.ROLE_COLORS)
    x = doc.mesh.vertices[:, 0]
    bands = np.digitize(x, np.linspace(x.min(), x.max(), n_groups + 3)[1:-1])  # FIXED, FREE, each group
    roles = (bands - 1).astype(np.int8)
    _, sc, _ = render(path, roles=roles)
    grey = 128.0
    seen = set()
    for part in sc.parts.parts:
        if part.texture is None:
            continue
        seen.add(part.role)
        texel = grey * np.asarray(part.actor.GetProperty().GetColor())
        assert np.all(texel >= 0.8 * grey), (part.role, texel)
        if part.role != FREE:  # and the tint is there: the held region and each handle group show
            assert np.max(grey - texel) >= 4.0, (part.role, texel)
    assert seen == set(range(FIXED, n_groups + 1))


def painted_ply(folder):
    """A sphere in a PLY with vertex colours: red where x > 0, green elsewhere."""
    from plyfile import PlyData, PlyElement

    s = pv.Sphere(theta_resolution=40, phi_resolution=40)
    V = np.asarray(s.points, dtype=np.float32)
    F = np.asarray(s.faces).reshape(-1, 4)[:, 1:]
    red = V[:, 0] > 0
    vert = np.zeros(len(V), dtype=[("x", "f4"), ("y", "f4"), ("z", "f4"), ("red", "u1"), ("green", "u1"),
                                   ("blue", "u1")])
    vert["x"], vert["y"], vert["z"] = V.T
    vert["red"] = np.where(red, 220, 30)
    vert["green"] = np.where(red, 30, 200)
    vert["blue"] = 30
    face = np.zeros(len(F), dtype=[("vertex_indices", "i4", (3,))])
    face["vertex_indices"] = F
    p = folder / "painted.ply"
    PlyData([PlyElement.describe(vert, "vertex"), PlyElement.describe(face, "face")]).write(str(p))
    return p


def test_vertex_colours_are_shown(tmp_path):
    p = painted_ply(tmp_path)
    img, sc, _ = render(p)
    assert sc.look_mode == "colors"
    r = img.astype(int)
    reddish = (r[..., 0] - r[..., 1] > 80)
    greenish = (r[..., 1] - r[..., 0] > 80)
    assert reddish.mean() > 0.03 and greenish.mean() > 0.03
    plain, _, _ = render(p, mode="plain")
    assert (plain[..., 0] - plain[..., 1] > 80).mean() < 0.001


@pytest.mark.slow  # (a new process: Python, VTK and a cage build of its own)
def test_the_screenshot_shows_the_asset_as_the_window_does(tmp_path):
    """`hybridedit --screenshot`: a textured OBJ with its texture's two colours, a PLY with its vertex colours."""
    import subprocess
    import sys

    from PIL import Image

    def shot(mesh) -> np.ndarray:
        out = tmp_path / f"{Path(mesh).stem}.png"
        r = subprocess.run([sys.executable, "-m", "hybridedit", "--screenshot", str(out), "--cage", "120", str(mesh)],
                           capture_output=True, text=True, timeout=180)
        assert r.returncode == 0, r.stderr
        return np.asarray(Image.open(out).convert("RGB")).astype(int)

    img = shot(uv_sphere_obj(tmp_path))
    assert share_near(img, CHECKER_A) > 0.02 and share_near(img, CHECKER_B) > 0.02
    img = shot(painted_ply(tmp_path))
    assert (img[..., 0] - img[..., 1] > 80).mean() > 0.02 and (img[..., 1] - img[..., 0] > 80).mean() > 0.02


def test_a_plain_mesh_has_no_look():
    m = Mesh(np.eye(3), np.array([[0, 1, 2]]))
    assert look_of(he.Document.from_mesh(m)) is None


def test_the_window_opens_a_textured_file_textured_and_keeps_it_through_a_drag(qtbot, tmp_path):
    from qtpy import QtCore

    from hybridedit.viewer.window.main_window import MainWindow

    Qt = QtCore.Qt
    path = uv_sphere_obj(tmp_path)
    w = MainWindow(cage_size=150)
    w.resize(900, 700)
    w.show()
    qtbot.waitExposed(w)
    w.activateWindow()
    qtbot.waitActive(w)
    w.view.setFocus()
    assert w.loading.open_path(path)
    qtbot.waitUntil(lambda: w.session is not None and w.jobs.worker is None, timeout=60000)
    s = w.session
    assert w.scene.look_mode == "texture" and w.actions_["look_texture"].isChecked()
    assert not w.actions_["look_colors"].isEnabled() and w.actions_["look_plain"].isEnabled()

    def shot():
        w.view.render()
        return np.asarray(w.view.screenshot(None, return_img=True))[..., :3].astype(int)

    img = shot()
    assert share_near(img, CHECKER_A) > 0.02 and share_near(img, CHECKER_B) > 0.02
    # a drag: the texture stays on, every seam copy follows its vertex
    P = s.cage_positions
    s.selection.set_mask("roi", P[:, 0] > 0.0)
    s.selection.set_mask("handle", P[:, 0] > 0.8)
    w.sync.refresh_selection()
    key(qtbot, w, Qt.Key.Key_D)
    dc, _ = projected(w, s.handle_centroid()[None])
    a = to_widget(w, dc[0])
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -60))
    settled(qtbot, w)
    drawn = w.scene.parts.drawn_points()
    assert not np.any(np.isnan(drawn)) and np.allclose(drawn, s.shown_positions, atol=1e-5)
    assert share_near(shot(), CHECKER_A) > 0.02
    # View > Plain (Alt+3), and back (Alt+1)
    key(qtbot, w, Qt.Key.Key_3, Qt.KeyboardModifier.AltModifier)
    assert w.scene.look_mode == "plain" and w.actions_["look_plain"].isChecked()
    assert share_near(shot(), CHECKER_B) < 0.001  # (red is taken: the gizmo's X arrow)
    key(qtbot, w, Qt.Key.Key_1, Qt.KeyboardModifier.AltModifier)
    assert w.scene.look_mode == "texture" and share_near(shot(), CHECKER_A) > 0.02
    w.unsaved.set_modified(False)
    w.close()


def test_opening_a_file_or_a_mesh_gives_its_session_look_and_up_axis(tmp_path):
    """open_session (what the screenshot, hybridedit web and he.widget open with) reads what the
    window reads: the file's look, a note for a texture it cannot decode, and an up axis."""
    from hybridedit.viewer.model.opening import open_session

    path = uv_sphere_obj(tmp_path)
    opened = open_session(path, cage_size=60)
    s = opened.session
    assert s.path == Path(path) and s.cage_size == 60 and s.look is not None
    assert any(m.image is not None for m in s.look.materials)
    assert opened.notes == () and opened.up_axis in ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
    (tmp_path / "checker.png").write_bytes(b"not a PNG")
    assert any("checker.png" in n for n in open_session(path, cage_size=60).notes)
    (tmp_path / "checker.png").unlink()  # a texture the material names, not there: said, not silently plain
    assert any("checker.png" in n and "not there" in n for n in open_session(path, cage_size=60).notes)
    bare = open_session(Mesh(s.mesh.vertices, s.mesh.faces), cage_size=60)
    assert bare.session.path is None and bare.session.look is None and bare.notes == ()
    assert np.array_equal(bare.session.shown_positions, s.mesh.vertices)
