"""Displayed frame rate of the editor window while dragging, against a bare pyvista render.

    python benchmarks/window_fps.py MESH [--seconds 4] [--cage 0.05] [--size 1280x900]
    python benchmarks/window_fps.py --textured       (a generated 100K+ textured mesh)
    python benchmarks/window_fps.py --smoke [--textured]   (a small generated mesh, about a second)

Opens MESH in the real window (its own Xvfb when there is no display),
selects the top 5% of the shape along its longest axis as the handle and the
top 30% as the region of interest, and drags the handle in circles with real
Qt mouse events for a few seconds; in turns with the window (four slices
each, so both see the same machine load), a bare pyvista plotter renders the
same mesh (same normals, same size, same camera, anti-aliasing off) as fast
as it can, its points rewritten every frame as a drag would. Both rates are
cadences: frame intervals over the time from a slice's first frame on screen to
its last. A mesh with a texture is drawn with it in both (the window's default
for such a file): the bare plotter draws pyvista's own textured mesh, split at
the texture's seams as VTK needs.
Prints the frame split (per displayed frame, in ms) and last the line

    window_fps: <file> <n_vertices> displayed_fps=<x> bare_fps=<y> overhead=<bare_fps/displayed_fps>
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))  # the tests' virtual X server

from support.xvfb import ensure_display  # noqa: E402


def parse_size(text: str) -> tuple[int, int]:
    w, h = text.lower().split("x")
    return int(w), int(h)


def top_fraction(V: np.ndarray, fraction: float) -> np.ndarray:
    """Shape vertex indices in the top ``fraction`` of the bounding box along its longest axis."""
    axis = int(np.argmax(np.ptp(V, axis=0)))
    x = V[:, axis]
    lo, hi = float(x.min()), float(x.max())
    return np.flatnonzero(x >= hi - fraction * (hi - lo))


def run(mesh_path: Path, cage, size: tuple[int, int], seconds: float, look: str | None = None):
    """Drag in the window and render bare, in turns; returns (displayed fps, bare fps, n_vertices,
    per-frame split in ms, frame ms, view size)."""
    from qtpy import QtCore, QtGui, QtWidgets

    from hybridedit.viewer.input.mouse_gestures import DRAG
    from hybridedit.viewer.model.selection_masks import HANDLE, ROI
    from hybridedit.viewer.window.main_window import MainWindow

    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    w = MainWindow(cage_size=cage)
    w.polisher.enabled = False
    w.show()
    w.resize(*size)
    app.processEvents()
    w.loading.open_path(mesh_path)
    t0 = time.perf_counter()
    while w.jobs.worker is not None or w.session is None:
        app.processEvents(QtCore.QEventLoop.ProcessEventsFlag.AllEvents, 50)
        time.sleep(0.01)
        if time.perf_counter() - t0 > 900:
            raise SystemExit(f"window_fps: {mesh_path}: the window did not load the mesh")
    s = w.session
    V = s.mesh.vertices
    ed = s.editor
    for target, frac in ((ROI, 0.30), (HANDLE, 0.05)):
        m = np.zeros(s.n_cage, dtype=bool)
        m[ed.to_cage(top_fraction(V, frac), "shape")] = True
        s.selection.set_mask(target, m)
    w.sync.refresh_selection()
    if look is not None:
        w.options.set_look_mode(look)  # View > Texture / Colours / Plain
    w.options.set_mode(DRAG)
    w.scene.reset_camera()
    view = w.view
    view.request_render()
    for _ in range(20):
        app.processEvents()
        time.sleep(0.01)

    # press beside the gizmo (a drag in the view plane), then circle with the button down
    rect = view.rect()
    c = QtCore.QPointF(rect.width() * 0.3, rect.height() * 0.5)
    radius = 0.08 * rect.height()
    Qt = QtCore.Qt

    def send(kind, pos, buttons):
        button = Qt.MouseButton.LeftButton if kind != QtCore.QEvent.Type.MouseMove else Qt.MouseButton.NoButton
        ev = QtGui.QMouseEvent(kind, pos, view.mapToGlobal(pos), button, buttons, Qt.KeyboardModifier.NoModifier)
        QtWidgets.QApplication.sendEvent(view, ev)

    send(QtCore.QEvent.Type.MouseButtonPress, c, Qt.MouseButton.LeftButton)
    if w.controller.gesture is None:
        raise SystemExit("window_fps: the drag did not start (no handle?)")
    phase = [0.0]

    def move():
        phase[0] += 0.05
        p = c + QtCore.QPointF(radius * np.sin(phase[0]), radius * (1.0 - np.cos(phase[0])))
        send(QtCore.QEvent.Type.MouseMove, p, Qt.MouseButton.LeftButton)

    timer = QtCore.QTimer()
    timer.setInterval(8)  # a 125 Hz mouse
    timer.timeout.connect(move)
    shown: list[float] = []
    counting = [False]
    view.rendered.connect(lambda _s: shown.append(time.perf_counter()) if counting[0] else None)

    def window_slice(length: float) -> None:
        # Qt's own event loop, as in the editor (a Python loop of processEvents() would hold
        # Python's lock and starve the window's frame thread)
        loop = QtCore.QEventLoop()
        QtCore.QTimer.singleShot(int(length * 1e3), loop.quit)
        timer.start()
        loop.exec()
        timer.stop()
        w.dragging.frames.flush()  # the frame of the last move
        app.processEvents()

    window_slice(min(1.0, 0.3 * seconds))  # warm-up
    drawn = w.scene.look if w.scene.look_mode == "texture" else None
    bare = BarePlotter(np.asarray(s.shape_positions), np.asarray(w.scene.normals32), s.mesh.faces,
                       (view.width(), view.height()), w.scene.renderer.GetActiveCamera(), look=drawn)
    bare.run(0.5)  # warm-up
    # window and bare plotter in alternating slices, so that both see the same machine load; each
    # slice's rate is its frames' steady cadence (intervals between the first and the last frame it
    # put on screen), so that neither the window's first frame of a slice (the drag picking up again)
    # nor its last one cut off by the slice's end counts against either side
    view.split.reset()
    window_frames = window_seconds = bare_frames = bare_seconds = 0.0
    slice_len = seconds / ROUNDS
    n = 0
    for _ in range(ROUNDS):
        shown.clear()
        counting[0] = True
        window_slice(slice_len)
        counting[0] = False
        n += len(shown)
        if len(shown) >= 2:
            window_frames += len(shown) - 1
            window_seconds += shown[-1] - shown[0]
        k, dt = bare.run(slice_len, np.asarray(s.shape_positions))
        bare_frames += k
        bare_seconds += dt
    send(QtCore.QEvent.Type.MouseButtonRelease, c, Qt.MouseButton.NoButton)
    fps = window_frames / window_seconds if window_seconds > 0 else 0.0
    split = {k: view.split.seconds[k] * 1e3 / max(n, 1) for k in view.split.seconds}
    frame_ms = 1e3 / fps if fps > 0 else float("inf")
    # engine, points and normals run on the frame thread, beside the render: not part of the UI thread's frame
    ui = sum(v for k, v in split.items() if k not in FRAME_THREAD)
    split["other"] = max(frame_ms - ui, 0.0)
    vsize = (view.width(), view.height())
    bare.close()
    w.unsaved.set_modified(False)  # no question on closing
    mode = w.scene.look_mode
    w.close()
    app.processEvents()
    return fps, bare_frames / bare_seconds, s.mesh.n_vertices, split, frame_ms, vsize, mode


ROUNDS = 4
"""Window and bare plotter take turns this many times (each a quarter of --seconds)."""
FRAME_THREAD = ("engine", "points", "normals")
"""Stages computed on the window's frame thread (they overlap the render)."""


class BarePlotter:
    """A bare pyvista plotter showing the same mesh (same normals, same size, same camera, one
    headlight, anti-aliasing off), its points rewritten every frame as a drag would; with a
    ``look`` (:class:`hybridedit.viewer.look.Look`), its render mesh with the first texture."""

    def __init__(self, shape, normals, faces, size: tuple[int, int], camera, look=None) -> None:
        import pyvista as pv

        source = np.arange(len(shape)) if look is None else look.source
        tri = faces if look is None else look.triangles
        self.source = source
        poly = pv.PolyData(np.asarray(shape, dtype=np.float32)[source],
                           faces=np.hstack([np.full((len(tri), 1), 3), tri]).ravel())
        poly.point_data["Normals"] = np.asarray(normals, dtype=np.float32)[source]
        poly.GetPointData().SetActiveNormals("Normals")
        texture = None
        if look is not None and look.uv is not None:
            poly.active_texture_coordinates = look.uv
            image = next((m.image for m in look.materials if m.image is not None), None)
            texture = None if image is None else pv.Texture(np.ascontiguousarray(image[::-1]))
            if texture is not None:
                texture.interpolate = True  # as the window draws it (linear; no measurable cost)
        pl = pv.Plotter(window_size=list(size), lighting="none")
        pl.ren_win.SetMultiSamples(0)  # anti-aliasing off, as in the window with software OpenGL
        pl.disable_anti_aliasing()
        pl.add_light(pv.Light(light_type="headlight"))  # the window's one light
        pl.add_mesh(poly, color=(0.89, 0.82, 0.72) if texture is None else None, texture=texture,
                    smooth_shading=False)  # lit with the given normals
        pl.show(interactive_update=True, auto_close=False)
        pl.renderer.GetActiveCamera().DeepCopy(camera)
        pl.renderer.ResetCameraClippingRange()
        self.pl, self.poly = pl, poly
        self.n = 0

    def run(self, seconds: float, shape=None) -> tuple[int, float]:
        """Render for ``seconds``; returns (frame intervals, their seconds): the cadence from the
        first frame's end to the last one's, as the window's is measured."""
        pts = self.poly.points
        base = pts.copy() if shape is None else np.asarray(shape, dtype=np.float32)[self.source]
        ends = []
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < seconds or len(ends) < 2:
            self.n += 1
            pts[:] = base + np.float32(1e-4 * (self.n % 2))
            self.poly.GetPoints().Modified()
            self.pl.render()
            ends.append(time.perf_counter())
        return len(ends) - 1, ends[-1] - ends[0]

    def close(self) -> None:
        self.pl.close()


def textured_mesh(n_lat: int, n_lon: int) -> Path:
    """A UV sphere stretched along X with a checker texture (its u = 0 / 1 meridian a seam), written
    as OBJ + MTL + PNG to a temporary folder; (n_lat + 1) * n_lon vertices."""
    from PIL import Image

    folder = Path(tempfile.mkdtemp(prefix="window_fps-tex-"))
    th = np.pi * np.arange(n_lat + 1) / n_lat
    ph = 2 * np.pi * np.arange(n_lon) / n_lon
    T, P = np.meshgrid(th, ph, indexing="ij")
    V = np.stack([2.0 * np.sin(T) * np.cos(P), np.cos(T), np.sin(T) * np.sin(P)], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_lat), np.arange(n_lon), indexing="ij")
    i, j = i.ravel(), j.ravel()
    vid = lambda a, b: a * n_lon + b % n_lon + 1  # noqa: E731
    tid = lambda a, b: a * (n_lon + 1) + b + 1  # noqa: E731
    corners = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
    faces = np.stack([np.stack([vid(a, b), tid(a, b)], axis=1) for a, b in corners], axis=1)  # (q, 4, 2)
    ti, tj = np.meshgrid(np.arange(n_lat + 1), np.arange(n_lon + 1), indexing="ij")
    uv = np.stack([tj.ravel() / n_lon, 1.0 - ti.ravel() / n_lat], axis=1)
    with open(folder / "textured.obj", "w") as f:
        f.write("mtllib textured.mtl\nusemtl checker\n")
        np.savetxt(f, V, fmt="v %.6f %.6f %.6f")
        np.savetxt(f, uv, fmt="vt %.6f %.6f")
        np.savetxt(f, faces.reshape(len(faces), 8), fmt="f %d/%d %d/%d %d/%d %d/%d")
    (folder / "textured.mtl").write_text("newmtl checker\nKd 1 1 1\nmap_Kd checker.png\n")
    k = (np.arange(512) // 32)
    img = np.where(((k[:, None] + k[None, :]) % 2 == 0)[..., None], [230, 40, 40], [40, 60, 220]).astype(np.uint8)
    Image.fromarray(img).save(folder / "checker.png")
    return folder / "textured.obj"


def smoke_mesh() -> Path:
    """A small closed shape (about 10K vertices) written to a temporary file."""
    import trimesh

    from hybridedit.fileio.meshfiles import write_mesh
    from hybridedit.core.mesh import Mesh

    s = trimesh.creation.icosphere(subdivisions=5)
    v = np.asarray(s.vertices) * np.array([2.0, 1.0, 1.0])
    p = Path(tempfile.mkdtemp(prefix="window_fps-")) / "smoke.ply"
    write_mesh(p, Mesh(v, np.asarray(s.faces), name="smoke"))
    return p


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mesh", nargs="?", help="mesh file (OBJ, PLY, STL, OFF)")
    ap.add_argument("--seconds", type=float, default=4.0, help="how long to drag (and to render bare)")
    ap.add_argument("--cage", type=float, default=0.05, help="cage size as a fraction (default 0.05)")
    ap.add_argument("--size", type=parse_size, default=(1280, 900), help="window size, WxH (default 1280x900)")
    ap.add_argument("--smoke", action="store_true", help="a quick run on a small generated mesh")
    ap.add_argument("--look", choices=("texture", "colors", "plain"),
                    help="draw the mesh so (View menu; default: what its file has), the bare plotter alike")
    ap.add_argument("--textured", action="store_true",
                    help="without MESH: a generated textured mesh (100K+ vertices; small with --smoke)")
    args = ap.parse_args(argv)
    if args.textured and not args.mesh:
        args.mesh = str(textured_mesh(60, 120) if args.smoke else textured_mesh(300, 400))
    if args.smoke:
        mesh, seconds = Path(args.mesh) if args.mesh else smoke_mesh(), 1.0
    elif args.mesh:
        mesh, seconds = Path(args.mesh), args.seconds
    else:
        ap.error("give a mesh file (or --smoke)")
    if not mesh.is_file():
        print(f"window_fps: {mesh}: no such file", file=sys.stderr)
        return 2
    vd = ensure_display()
    if vd is not None and not vd.display:
        print(f"window_fps: no display and {vd.problem}", file=sys.stderr)
        return 2
    if sys.platform.startswith("linux"):
        os.environ.setdefault("QT_QPA_PLATFORM", "xcb")
    # (a private Xvfb ends with this process, after Qt has let go of it)
    fps, bare, n, split, frame_ms, vsize, mode = run(mesh, args.cage, args.size, seconds, args.look)
    print(f"view {vsize[0]}x{vsize[1]} px, {n:,} vertices, drawn {mode}, dragged {seconds:.1f} s")
    print(f"{'stage':<12} {'ms per displayed frame':>24}")
    for k, v in split.items():
        where = " (frame thread, beside the render)" if k in FRAME_THREAD else ""
        print(f"{k:<12} {v:>24.1f}{where}")
    print(f"{'frame':<12} {frame_ms:>24.1f}")
    print(f"{'bare frame':<12} {1e3 / bare if bare else float('inf'):>24.1f}")
    overhead = bare / fps if fps > 0 else float("inf")
    print(f"window_fps: {mesh.name} {n} displayed_fps={fps:.2f} bare_fps={bare:.2f} overhead={overhead:.2f}")
    return 0


if __name__ == "__main__":
    from hybridedit.viewer.shutdown import leave

    leave(main())  # no interpreter teardown of Qt and VTK (it can abort after the work is done)
