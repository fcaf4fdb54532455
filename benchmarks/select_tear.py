"""Does the window's default selection tear a limb? Rectangles over an arm and a leg from the front,
a drag of the hand or foot, in the real window (real Qt mouse events), with Select Through off
(the default) and on.

    python benchmarks/select_tear.py [MESH ...] [--pixels 100] [--smoke]

For each mesh (default: data/creature.ply and, when present, ../shared/meshes/armadillo43k.obj)
and each limb, the ROI rectangle is drawn around the limb's shape vertices on screen and the
handle rectangle around its end, Select mode, as a user would; the handle is then dragged
``--pixels`` in Drag mode and the settled pose measured (the polish is off: the drag's own
result). Printed per edit and mode: the cage points taken (ROI, handle), the relative RMS edge
error of the whole shape, the largest edge stretch, and whether the window warned of a tear
before the drag. Last: the default mode's edge error over Select Through's (the target is at
most 1.2).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))  # the tests' virtual X server

from support.xvfb import ensure_display  # noqa: E402


def limbs(V: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray, tuple[int, int]]]:
    """{name: (ROI vertices, handle vertices, drag direction in pixels (right, up))} of a shape standing
    up along +Y, facing +Z: the arm on the +X side (beyond the shoulder) and the leg on the +X side."""
    lo, hi = V.min(axis=0), V.max(axis=0)
    r = (V - lo) / (hi - lo)
    arm = (r[:, 0] > 0.78) & (r[:, 1] > 0.45)
    hand = (r[:, 0] > 0.92) & (r[:, 1] > 0.45)
    leg = (r[:, 1] < 0.28) & (r[:, 0] > 0.5)
    foot = (r[:, 1] < 0.07) & (r[:, 0] > 0.5)
    return {"arm": (np.flatnonzero(arm), np.flatnonzero(hand), (0, 1)),
            "leg": (np.flatnonzero(leg), np.flatnonzero(foot), (1, 0))}


def run(path: Path, pixels: int, size=(1100, 850), cage: float = 0.05) -> list[dict]:
    from qtpy import QtCore, QtGui, QtWidgets

    from hybridedit.core.mesh import edge_error_stats
    from hybridedit.viewer.model.picking import project_points
    from hybridedit.viewer.window.main_window import MainWindow

    Qt = QtCore.Qt
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication([])
    w = MainWindow(cage_size=cage)
    w.polisher.enabled = False
    w.show()
    w.resize(*size)
    w.activateWindow()
    app.processEvents()
    w.loading.open_path(path)
    t0 = time.perf_counter()
    while w.jobs.worker is not None or w.session is None:
        app.processEvents(QtCore.QEventLoop.ProcessEventsFlag.AllEvents, 50)
        time.sleep(0.01)
        if time.perf_counter() - t0 > 900:
            raise SystemExit(f"select_tear: {path}: the window did not load the mesh")
    s = w.session
    view = w.view

    def pump(seconds: float = 0.05) -> None:
        end = time.perf_counter() + seconds
        while time.perf_counter() < end:
            app.processEvents()
            time.sleep(0.005)

    def send(kind, pos: QtCore.QPointF, button, buttons) -> None:
        ev = QtGui.QMouseEvent(kind, pos, view.mapToGlobal(pos), button, buttons, Qt.KeyboardModifier.NoModifier)
        QtWidgets.QApplication.sendEvent(view, ev)
        app.processEvents()

    def gesture(a: QtCore.QPointF, b: QtCore.QPointF, steps: int = 8) -> None:
        send(QtCore.QEvent.Type.MouseButtonPress, a, Qt.MouseButton.LeftButton, Qt.MouseButton.LeftButton)
        for k in range(1, steps + 1):
            send(QtCore.QEvent.Type.MouseMove, a + (b - a) * (k / steps), Qt.MouseButton.NoButton,
                 Qt.MouseButton.LeftButton)
            pump(0.01)
        send(QtCore.QEvent.Type.MouseButtonRelease, b, Qt.MouseButton.LeftButton, Qt.MouseButton.NoButton)
        pump(0.05)

    def box(rows: np.ndarray) -> tuple[QtCore.QPointF, QtCore.QPointF]:
        d, _ = project_points(s.shape_positions[rows], w.scene.composite_matrix(), w.scene.display_size())
        lo, hi = d[:, :2].min(axis=0) - 4, d[:, :2].max(axis=0) + 4
        a, b = view.to_widget(lo[0], hi[1]), view.to_widget(hi[0], lo[1])
        return QtCore.QPointF(a), QtCore.QPointF(b)

    out = []
    edges = s.edges
    for name, (roi, handle, (dx, dy)) in limbs(s.mesh.vertices).items():
        for through in (False, True):
            w.undo_commands.reset_pose()
            s.selection.clear_all()
            w.sync.refresh_selection()
            w.scene.reset_camera(tilted=False)
            view.request_render()
            pump(0.2)
            w.controller.set_select_through(through)
            w.options.set_mode("select")
            w.selecting.set_target("roi")
            gesture(*box(roi))
            w.selecting.set_target("handle")
            gesture(*box(handle))
            warned = "tears the shape" in w.status.current_message()
            w.options.set_mode("drag")
            dc, _ = project_points(s.handle_centroid()[None], w.scene.composite_matrix(), w.scene.display_size())
            a = QtCore.QPointF(view.to_widget(dc[0, 0], dc[0, 1]))
            gesture(a, a + QtCore.QPointF(dx * pixels, -dy * pixels))
            w.posing.finish_settle()
            pump(0.1)
            rrms, stretch = edge_error_stats(s.mesh.vertices, s.shape_positions, edges)
            sel = s.selection
            out.append({"mesh": path.name, "edit": name, "mode": "Select Through" if through else "default",
                        "roi": int(np.count_nonzero(sel.roi & ~sel.all_handles)), "handle": int(sel.all_handles.sum()),
                        "rrms": rrms, "stretch": stretch, "warned": warned})
    w.unsaved.set_modified(False)
    w.close()
    app.processEvents()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("meshes", nargs="*", type=Path)
    ap.add_argument("--pixels", type=int, default=100, help="how far the handle is dragged (default 100)")
    ap.add_argument("--smoke", action="store_true", help="a small generated figure, about a second")
    args = ap.parse_args()
    display = ensure_display("1280x1024x24")
    if display is not None and display.problem:
        raise SystemExit(f"select_tear: no display: {display.problem}")
    meshes = list(args.meshes)
    tmp = None
    if args.smoke:
        import tempfile

        from hybridedit.fileio.meshfiles import write_mesh

        tmp = tempfile.TemporaryDirectory()
        meshes = [Path(tmp.name) / "figure.ply"]
        write_mesh(meshes[0], figure())
    elif not meshes:
        meshes = [ROOT / "data" / "creature.ply"]
        arm = ROOT.parent / "shared" / "meshes" / "armadillo43k.obj"
        if arm.is_file():
            meshes.append(arm)
    rows = []
    for m in meshes:
        rows += run(m, args.pixels, cage=0.3 if args.smoke else 0.05)
    head = f"{'mesh':>18} {'edit':>5} {'selection':>15} {'ROI':>6} {'handle':>7} {'RRMS-E %':>9} " \
           f"{'max stretch %':>14} {'warned':>7}"
    print(f"# select_tear: rectangles from the front, a {args.pixels} px drag, settled, no polish")
    print(head)
    print("-" * len(head))
    for r in rows:
        print(f"{r['mesh']:>18} {r['edit']:>5} {r['mode']:>15} {r['roi']:>6,} {r['handle']:>7,} {r['rrms']:>9.2f} "
              f"{r['stretch']:>14.1f} {'yes' if r['warned'] else 'no':>7}")
    print("-" * len(head))
    for i in range(0, len(rows), 2):
        a, b = rows[i], rows[i + 1]
        print(f"{a['mesh']} {a['edit']}: default / Select Through edge error = {a['rrms'] / b['rrms']:.2f}")
    if tmp is not None:
        tmp.cleanup()


def figure():
    """A small standing figure for the smoke run: a body, two arms out to the sides, two legs."""
    import trimesh

    from hybridedit.core.mesh import Mesh

    parts = [trimesh.creation.capsule(height=1.2, radius=0.45, count=[16, 16]),
             trimesh.creation.capsule(height=1.6, radius=0.14, count=[12, 12]),
             trimesh.creation.capsule(height=1.6, radius=0.14, count=[12, 12]),
             trimesh.creation.capsule(height=1.0, radius=0.18, count=[12, 12]),
             trimesh.creation.capsule(height=1.0, radius=0.18, count=[12, 12])]
    turn = trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0])
    up = trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0])
    parts[0].apply_transform(up)
    for k, sx in ((1, 1), (2, -1)):
        parts[k].apply_transform(turn)
        parts[k].apply_translation([sx * 1.1, 0.4, 0])
    for k, sx in ((3, 1), (4, -1)):
        parts[k].apply_transform(up)
        parts[k].apply_translation([sx * 0.25, -1.3, 0])
    body = trimesh.util.concatenate(parts)  # (overlapping parts: a cage per part, tied by links)
    return Mesh(np.asarray(body.vertices), np.asarray(body.faces), name="figure")


if __name__ == "__main__":
    main()
