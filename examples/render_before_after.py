"""Before / after picture: the rest shape and the edited one side by side, off-screen.

Raises the +X arm as in scripted_edit.py and renders with pyvista, without a
window: on the left the rest shape coloured by role (orange handle, green
region of interest, grey fixed), on the right the deformed shape coloured by how
much its edges stretch or shrink (per vertex, percent).

Rendering needs an OpenGL context. With no DISPLAY (a server, CI, ssh) on Linux
the script starts its own virtual X server if ``Xvfb`` is installed (apt-get
install xvfb) and stops it at the end; otherwise VTK tries its own off-screen
fallbacks (EGL, then OSMesa), which work where those libraries are installed.

Run from the repository root:

    .venv/bin/python examples/render_before_after.py                # data/creature.ply
    .venv/bin/python examples/render_before_after.py my.obj --out /tmp --cage 1000

Writes ``before_after.png`` to ``--out`` (default: the current folder).
"""

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

import hybridedit as he
from hybridedit.cli import parse_cage_size
from hybridedit.core.mesh import edge_stretch, vertex_stretch

DEFAULT_MESH = Path(__file__).resolve().parent.parent / "data" / "creature.ply"


def start_xvfb_if_needed() -> subprocess.Popen | None:
    """With no DISPLAY on Linux, start Xvfb on a free display and point DISPLAY at it."""
    if not sys.platform.startswith("linux") or os.environ.get("DISPLAY") or not shutil.which("Xvfb"):
        return None
    read_end, write_end = os.pipe()  # Xvfb writes the display number it picked here
    proc = subprocess.Popen(["Xvfb", "-displayfd", str(write_end), "-screen", "0", "1280x1024x24",
                             "-nolisten", "tcp"], pass_fds=(write_end,),
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(write_end)
    with os.fdopen(read_end) as fh:
        number = fh.readline().strip()
    if not number.isdigit():
        proc.kill()
        proc.wait()
        return None
    os.environ["DISPLAY"] = f":{number}"
    return proc


ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument("mesh", nargs="?", default=DEFAULT_MESH, help="input mesh (default data/creature.ply)")
ap.add_argument("--out", default=".", help="output folder (default: the current folder)")
ap.add_argument("--cage", type=parse_cage_size, default=0.05, help="cage vertices (2000) or fraction (0.05)")
ap.add_argument("--degrees", type=float, default=40.0, help="how far to raise the arm")
ap.add_argument("--size", type=int, nargs=2, default=(1600, 800), metavar=("W", "H"), help="image size")
ap.add_argument("--save", help="also save the edited mesh here (the input's format keeps everything it had)")
args = ap.parse_args()

editor = he.open(args.mesh, args.cage, cache=True)
mesh = editor.mesh
v = mesh.vertices
lo, hi = mesh.bbox()
rel = (v - lo) / (hi - lo)
hand = np.flatnonzero(rel[:, 0] > 0.92)
arm = np.flatnonzero(rel[:, 0] > 0.65)
shoulder = v[arm[rel[arm, 0] < 0.68]].mean(axis=0)
editor.set_selection(hand, roi=arm)
deformed = editor.pose(rotate={"axis": (0, 0, 1), "degrees": args.degrees, "center": shoulder})  # solved
if args.save:
    for note in editor.save(args.save):  # the input file with the new positions, nothing dropped
        print(f"note: {note}")

edges = mesh.edges()
stretch = 100 * vertex_stretch(mesh.n_vertices, edges, edge_stretch(v, deformed, edges))
role = np.zeros(mesh.n_vertices)
role[arm], role[hand] = 1, 2

xvfb = start_xvfb_if_needed()
try:
    import pyvista as pv

    rest = pv.PolyData.from_regular_faces(v, mesh.faces)
    rest["role"] = role
    posed = pv.PolyData.from_regular_faces(deformed, mesh.faces)
    posed["stretch %"] = stretch
    p = pv.Plotter(off_screen=True, shape=(1, 2), window_size=tuple(args.size), border=False)
    p.set_background("white")
    p.add_mesh(rest, scalars="role", cmap=["lightgray", "yellowgreen", "darkorange"], clim=(0, 2),
               show_scalar_bar=False, smooth_shading=True)
    p.add_text("rest: handle orange, region of interest green", font_size=11, color="black")
    p.subplot(0, 1)
    p.add_mesh(posed, scalars="stretch %", cmap="YlOrRd", clim=(0, max(1.0, np.percentile(stretch, 99))),
               smooth_shading=True, scalar_bar_args={"color": "black", "position_x": 0.3, "position_y": 0.01,
                                                     "width": 0.4, "height": 0.12,
                                                     "n_labels": 3, "fmt": "%.1f"})
    p.add_text(f"arm raised {args.degrees:g}\u00b0: RRMS edge error "
               f"{he.rrms_edge_error(v, deformed, edges):.2f}%", font_size=11, color="black")
    # Front view (looking down -Z, Y up), orthographic, both poses fitting each half of
    # the image with room at the top for the captions and at the bottom for the colour bar.
    p.link_views()
    both = np.vstack([v, deformed])
    lo, hi = both.min(axis=0), both.max(axis=0)
    center, extent = (lo + hi) / 2, hi - lo
    p.camera.focal_point = center
    p.camera.position = center + (0, 0, 2 * np.linalg.norm(extent) + 1e-9)
    p.camera.up = (0, 1, 0)
    p.enable_parallel_projection()
    aspect = args.size[0] / 2 / args.size[1]  # width / height of one half
    p.camera.parallel_scale = max(extent[1] / 2 / 0.72, extent[0] / 2 / aspect / 0.96)
    p.reset_camera_clipping_range()
    png = Path(args.out) / "before_after.png"
    png.parent.mkdir(parents=True, exist_ok=True)
    p.screenshot(png)
    p.close()
finally:
    if xvfb is not None:
        xvfb.terminate()
        xvfb.wait()
print(f"wrote {png} ({'Xvfb ' + os.environ['DISPLAY'] if xvfb else os.environ.get('DISPLAY') or 'no display'})")
